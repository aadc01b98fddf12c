// Scenes too big for memory are refused while the scene is read, naming the
// field that makes them big, before anything is allocated for them.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <malloc.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <optional>

#include "core/memory_budget.h"
#include "io/scene_io.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

Scene parse(const std::string& text) { return io::parse_scene(text, "test.json", "."); }

std::string with_objects(const std::string& objects) { return fmt::format(R"({{"objects": [{}]}})", objects); }

std::string box(double size, double spacing) {
  return fmt::format(R"({{"primitive": {{"type": "box", "size": [{0}, {0}, {0}]}}, "material": "gooey_jelly",
                          "lattice_spacing": {1}}})",
                     size, spacing);
}

std::string primitive(const std::string& fields) {
  return fmt::format(R"({{"primitive": {{{}}}, "material": "gooey_jelly", "lattice_spacing": 0.05}})", fields);
}

/// GOO_MEMORY_LIMIT set for the life of the object, then as it was.
class MemoryLimit {
 public:
  explicit MemoryLimit(const char* value) {
    if (const char* old = std::getenv("GOO_MEMORY_LIMIT")) old_ = old;
    ::setenv("GOO_MEMORY_LIMIT", value, 1);
  }
  ~MemoryLimit() {
    if (old_) ::setenv("GOO_MEMORY_LIMIT", old_->c_str(), 1);
    else ::unsetenv("GOO_MEMORY_LIMIT");
  }
  MemoryLimit(const MemoryLimit&) = delete;
  MemoryLimit& operator=(const MemoryLimit&) = delete;

 private:
  std::optional<std::string> old_;
};

TEST(SceneMemory, TheLimitIsGooMemoryLimitOrTheMachinesMemory) {
  {
    const MemoryLimit limit("3G");
    EXPECT_EQ(memory_limit_bytes(), 3ull << 30);
  }
  {
    const MemoryLimit limit("512MB");
    EXPECT_EQ(memory_limit_bytes(), 512ull << 20);
  }
  {
    const MemoryLimit limit("123456");
    EXPECT_EQ(memory_limit_bytes(), 123456u);
  }
  for (const char* bad : {"", "lots", "3X", "-1G", "0", "1e30"}) {
    const MemoryLimit limit(bad);
    EXPECT_TRUE(test::throws_error_containing([] { static_cast<void>(memory_limit_bytes()); }, "GOO_MEMORY_LIMIT"))
        << bad;
  }
  // Without it: physical memory (this machine has some), at most what a
  // 64-bit address space holds.
  ::unsetenv("GOO_MEMORY_LIMIT");
  EXPECT_GT(memory_limit_bytes(), 64ull << 20);
}

TEST(SceneMemory, ALatticeBeyondThirtyTwoBitIndicesIsRefusedAtOnce) {
  // A 1 m cube at 1 mm: 10⁹ cells, 1.2·10¹⁰ tetrahedron keys.
  const auto start = std::chrono::steady_clock::now();
  EXPECT_TRUE(test::throws_error_containing([] { parse(with_objects(box(1.0, 0.001))); },
                                            "/objects/0/lattice_spacing gives a lattice block of 1.01e+09 cells"));
  EXPECT_TRUE(test::throws_error_containing([] { parse(with_objects(box(1.0, 0.001))); }, "32-bit"));
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 5.0);
  EXPECT_NO_THROW(parse(with_objects(box(1.0, 0.01))));
}

TEST(SceneMemory, ScenesBeyondTheMemoryLimitAreRefusedNamingTheField) {
  const MemoryLimit limit("1G");
  // A 0.2 m box at 2 mm: 10⁶ cells and 12·10⁶ elements, ~3.7 GB.
  EXPECT_TRUE(test::throws_error_containing([] { parse(with_objects(box(0.2, 0.002))); },
                                            "/objects/0/lattice_spacing gives a lattice of"));
  EXPECT_NO_THROW(parse(with_objects(box(0.2, 0.005))));  // 240 MB
  // Surfaces: 10⁸ triangles of a sphere, a torus, a thin cylinder's bands.
  EXPECT_TRUE(test::throws_error_containing(
      [] { parse(with_objects(primitive(R"("type": "sphere", "radius": 0.1, "segments": 10000)"))); },
      "/objects/0/primitive/segments gives a surface of 1e+08 triangles"));
  EXPECT_TRUE(test::throws_error_containing(
      [] {
        parse(with_objects(primitive(
            R"("type": "torus", "major_radius": 0.1, "minor_radius": 0.03, "major_segments": 10000, "minor_segments": 9000)")));
      },
      "/objects/0/primitive/major_segments gives a surface of 1.8e+08 triangles"));
  EXPECT_TRUE(test::throws_error_containing(
      [] { parse(with_objects(primitive(R"("type": "cylinder", "radius": 0.05, "height": 10, "segments": 10000)"))); },
      "/objects/0/primitive/segments gives a surface of"));
  EXPECT_TRUE(test::throws_error_containing(
      [] { parse(with_objects(primitive(R"("type": "box", "size": [0.2, 0.2, 0.2], "subdivisions": 1000)"))); },
      "/objects/0/primitive/subdivisions gives a surface of 1.2e+07 triangles"));
  // Two objects that fit alone but not together: the second is named.
  const std::string half = box(0.2, 0.0035);  // ~0.6 GB each
  EXPECT_NO_THROW(parse(with_objects(half)));
  EXPECT_TRUE(test::throws_error_containing([&] { parse(with_objects(half + ", " + half)); },
                                            "/objects/1/lattice_spacing"));
  EXPECT_TRUE(test::throws_error_containing([&] { parse(with_objects(half + ", " + half)); }, "beside the"));
}

TEST(SceneMemory, TheShippedScenesFitInTwoGigabytes) {
  // Our own scenes, the armadillo and the bunny press among them, are not
  // refused on a small machine (their set-up needs far less).
  const MemoryLimit limit("2G");
  for (const auto& entry : std::filesystem::directory_iterator(std::filesystem::path(GOO_SOURCE_DIR) / "scenes")) {
    if (entry.path().extension() != ".json") continue;
    SCOPED_TRACE(entry.path().string());
    EXPECT_NO_THROW(io::read_scene(entry.path()));
  }
}

#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__)
struct HeldBlock {
  std::size_t mapped_growth;  ///< bytes mapped for blocks of their own, held minus before
  std::size_t heap_shrink;    ///< heap bytes held minus after the free
};

/// A block of `bytes` allocated, written to and freed again (through a
/// volatile pointer: the pair is not elided), and what glibc did for it.
HeldBlock hold_and_free(std::size_t bytes) {
  static void* (*volatile allocate)(std::size_t) = std::malloc;
  const struct mallinfo2 before = mallinfo2();
  auto* block = static_cast<unsigned char*>(allocate(bytes));
  EXPECT_NE(block, nullptr);
  std::memset(block, 1, bytes);
  const struct mallinfo2 held = mallinfo2();
  std::free(block);
  const struct mallinfo2 after = mallinfo2();
  return {held.hblkhd > before.hblkhd ? held.hblkhd - before.hblkhd : 0,
          held.arena > after.arena ? held.arena - after.arena : 0};
}

TEST(SceneMemory, FreedMemoryIsKeptForTheNextAllocations) {
  // With glibc's initial settings a 16 MB block is mapped for itself (and
  // unmapped when freed); after keep_freed_memory() it comes from the heap,
  // which does not shrink when it is freed.
  constexpr std::size_t kBlock = std::size_t{16} << 20;
  mallopt(M_MMAP_THRESHOLD, 128 * 1024);
  mallopt(M_TRIM_THRESHOLD, 128 * 1024);
  // The heap's free top returned first: the tests before this one (in the
  // same process) may have left more than a block free at the top, which
  // would serve it whatever the settings.
  malloc_trim(0);
  EXPECT_GE(hold_and_free(kBlock).mapped_growth, kBlock);
  keep_freed_memory();
  for (int round = 0; round < 2; ++round) {
    const HeldBlock kept = hold_and_free(kBlock);
    EXPECT_EQ(kept.mapped_growth, 0u);
    EXPECT_EQ(kept.heap_shrink, 0u);
  }
}
#endif

}  // namespace
}  // namespace goo
