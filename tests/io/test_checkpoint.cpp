// Checkpoints: exact round trip, refusal of damaged files, atomic replacement,
// and a layout an independent HDF5 client reads.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>

#include "io/checkpoint.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

StateRecord sample_record() {
  StateRecord r;
  r.put("time", 0.125);
  r.put("steps", std::int64_t{123456789012});
  Points x(50, 3);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (Eigen::Index i = 0; i < x.rows(); ++i)
    for (int k = 0; k < 3; ++k) x(i, k) = u(rng) * 1e3;
  x(3, 1) = 5e-324;  // a subnormal survives
  r.put_matrix("bodies/0/positions", x);
  r.put_vector("bodies/0/masses", Eigen::VectorXd::LinSpaced(50, 0.1, 5.0));
  Tets tets(2, 4);
  tets << 0, 1, 2, 3, 4, 5, 6, 49;
  r.put("bodies/0/tets", tets);
  r.put("bodies/0/Fp", std::vector<Eigen::Matrix3d>{Eigen::Matrix3d::Identity(), 2.0 * Eigen::Matrix3d::Ones()});
  r.put("bodies/0/pinned", std::vector<Index>{});  // empty arrays too
  r.put_matrix("bodies/0/empty", Eigen::MatrixXd(0, 3));
  r.put_string("bodies/0/name", "jelly");
  r.put_string("scene/text", "{\"objects\": [\"ü\"]}\n");
  return r;
}

std::string read_bytes(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_bytes(const std::filesystem::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out << bytes;
}

TEST(Checkpoint, RoundTripIsExact) {
  test::TempDir dir;
  const StateRecord r = sample_record();
  io::write_checkpoint(dir / "c.h5", r);
  const StateRecord back = io::read_checkpoint(dir / "c.h5");
  EXPECT_TRUE(back == r);
  EXPECT_EQ(back.real("time"), 0.125);
  EXPECT_EQ(back.integer("steps"), 123456789012);
  EXPECT_EQ(back.string("scene/text"), r.string("scene/text"));
  EXPECT_EQ(back.points("bodies/0/positions")(3, 1), 5e-324);
  // The same record gives the same bytes (no time stamps in the file).
  io::write_checkpoint(dir / "d.h5", r);
  EXPECT_EQ(read_bytes(dir / "c.h5"), read_bytes(dir / "d.h5"));
}

TEST(Checkpoint, TruncatedFilesAreRefused) {
  test::TempDir dir;
  io::write_checkpoint(dir / "c.h5", sample_record());
  const std::string bytes = read_bytes(dir / "c.h5");
  for (const std::size_t keep : {bytes.size() - 1, bytes.size() / 2, std::size_t{600}, std::size_t{100}, std::size_t{0}}) {
    write_bytes(dir / "t.h5", bytes.substr(0, keep));
    EXPECT_TRUE(test::throws_error_containing([&] { io::read_checkpoint(dir / "t.h5"); }, "t.h5")) << keep;
  }
  write_bytes(dir / "t.h5", bytes.substr(0, bytes.size() - 10));
  EXPECT_TRUE(test::throws_error_containing([&] { io::read_checkpoint(dir / "t.h5"); }, "truncated"));
}

TEST(Checkpoint, EveryFlippedBitIsRefused) {
  test::TempDir dir;
  io::write_checkpoint(dir / "c.h5", sample_record());
  const std::string bytes = read_bytes(dir / "c.h5");
  // Bytes spread over the whole file: header, HDF5 metadata and data.
  int tried = 0;
  for (std::size_t at = 3; at < bytes.size(); at += bytes.size() / 97 + 1) {
    std::string flipped = bytes;
    flipped[at] = static_cast<char>(flipped[at] ^ (1 << (at % 8)));
    write_bytes(dir / "f.h5", flipped);
    EXPECT_TRUE(test::throws_error_containing([&] { io::read_checkpoint(dir / "f.h5"); }, "f.h5")) << "byte " << at;
    ++tried;
  }
  EXPECT_GT(tried, 90);
  // A flip in the data is caught by the checksum, with that diagnosis.
  std::string flipped = bytes;
  flipped[bytes.size() / 2] = static_cast<char>(flipped[bytes.size() / 2] ^ 0x10);
  write_bytes(dir / "f.h5", flipped);
  EXPECT_TRUE(test::throws_error_containing([&] { io::read_checkpoint(dir / "f.h5"); }, "corrupt checkpoint"));
}

TEST(Checkpoint, WrongVersionAndForeignFilesAreRefused) {
  test::TempDir dir;
  io::write_checkpoint(dir / "c.h5", sample_record());
  std::string bytes = read_bytes(dir / "c.h5");
  const auto at = bytes.find("format_version 1");
  ASSERT_NE(at, std::string::npos);
  bytes[at + 15] = '7';
  write_bytes(dir / "v.h5", bytes);
  EXPECT_TRUE(test::throws_error_containing([&] { io::read_checkpoint(dir / "v.h5"); }, "format version 7"));
  write_bytes(dir / "x.h5", std::string(2000, 'x'));
  EXPECT_TRUE(test::throws_error_containing([&] { io::read_checkpoint(dir / "x.h5"); }, "not a goo checkpoint"));
  EXPECT_TRUE(test::throws_error_containing([&] { io::read_checkpoint(dir / "none.h5"); }, "none.h5"));
}

TEST(Checkpoint, AnInterruptedWriteLeavesThePreviousOneIntact) {
  test::TempDir dir;
  StateRecord first = sample_record();
  io::write_checkpoint(dir / "c.h5", first);
  const std::string before = read_bytes(dir / "c.h5");
  StateRecord second = first;
  second.put("time", 0.25);
  EXPECT_THROW(io::write_checkpoint(dir / "c.h5", second, [] { throw std::runtime_error("power cut"); }),
               std::runtime_error);
  EXPECT_EQ(read_bytes(dir / "c.h5"), before);
  int files = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir.path())) ++files;
  EXPECT_EQ(files, 1);  // no temporary file left behind
  EXPECT_EQ(io::read_checkpoint(dir / "c.h5").real("time"), 0.125);
}

TEST(Checkpoint, AWriterAbandonedMidStateLeavesThePreviousOneIntact) {
  // A run stopped (or failing) while its arrays stream into the file.
  test::TempDir dir;
  io::write_checkpoint(dir / "c.h5", sample_record());
  const std::string before = read_bytes(dir / "c.h5");
  {
    io::CheckpointWriter writer(dir / "c.h5");
    writer.put("time", 0.5);
    writer.put_matrix("bodies/0/positions", Eigen::MatrixXd::Ones(1000, 3));
    int files = 0;
    for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir.path())) ++files;
    EXPECT_EQ(files, 2);  // the checkpoint and the temporary file being written
  }
  EXPECT_EQ(read_bytes(dir / "c.h5"), before);
  int files = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir.path())) ++files;
  EXPECT_EQ(files, 1);
  // A field put twice is refused, naming it, and nothing is replaced.
  EXPECT_TRUE(test::throws_error_containing(
      [&] {
        io::CheckpointWriter writer(dir / "c.h5");
        writer.put("time", 0.5);
        writer.put("time", 0.75);
        writer.commit();
      },
      "time"));
  EXPECT_EQ(read_bytes(dir / "c.h5"), before);
}

TEST(Checkpoint, AStreamedStateEqualsTheRecordWrittenWhole) {
  // Arrays of many chunks, each kind the simulation puts, into a record and
  // straight into a writer; larger than the checksum's 1 MiB read block, so
  // that a flip past the first block is caught too.
  const Index n = 100000;
  Points x(n, 3);
  Tets tets(n, 4);
  std::vector<Eigen::Matrix3d> matrices(static_cast<std::size_t>(n) / 4);
  std::vector<Index> parents(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) {
    const auto v = static_cast<double>(i);
    x.row(i) << v, 0.5 * v, -0.25 * v;
    tets.row(i) << i, i + 1, 3 * i, n - i;
    parents[static_cast<std::size_t>(i)] = n - i;
  }
  for (std::size_t k = 0; k < matrices.size(); ++k) matrices[k] = Eigen::Matrix3d::Random() * static_cast<double>(k);
  auto fill = [&](StateSink& sink) {
    sink.put("time", 0.5);
    sink.put_matrix("bodies/0/positions", x);
    sink.put("bodies/0/tets", tets);
    sink.put("bodies/0/Fp", matrices);
    sink.put("bodies/0/embedding_parent", parents);
    sink.put("bodies/0/surface_triangles", Triangles(0, 3));
    sink.put_string("scene/text", "{}");
  };
  StateRecord r;
  fill(r);
  test::TempDir dir;
  {
    io::CheckpointWriter writer(dir / "s.h5");
    fill(writer);
    writer.commit();
  }
  EXPECT_TRUE(io::read_checkpoint(dir / "s.h5") == r);
  io::write_checkpoint(dir / "w.h5", r);
  EXPECT_TRUE(io::read_checkpoint(dir / "w.h5") == r);
  const std::string bytes = read_bytes(dir / "s.h5");
  ASSERT_GT(bytes.size(), std::size_t{2} << 20);
  std::string flipped = bytes;
  const std::size_t at = (std::size_t{3} << 20) / 2;  // in the second block
  flipped[at] = static_cast<char>(flipped[at] ^ 0x04);
  write_bytes(dir / "f.h5", flipped);
  EXPECT_TRUE(test::throws_error_containing([&] { io::read_checkpoint(dir / "f.h5"); }, "corrupt checkpoint"));
}

TEST(Checkpoint, MissingOrMistypedFieldsAreNamed) {
  const StateRecord r = sample_record();
  EXPECT_TRUE(test::throws_error_containing([&] { (void)r.real("nope"); }, "'nope' is missing"));
  EXPECT_TRUE(test::throws_error_containing([&] { (void)r.real("steps"); }, "'steps' should hold reals"));
  EXPECT_TRUE(test::throws_error_containing([&] { (void)r.tets("bodies/0/pinned"); }, "bodies/0/pinned"));
}

/// h5dump (Debian's hdf5-tools, installed by scripts/setup-deps) reads the
/// documented layout: /state/... datasets, Fletcher32 filters, attributes.
TEST(Checkpoint, AnIndependentHdf5ClientReadsTheLayout) {
  test::TempDir dir;
  io::write_checkpoint(dir / "c.h5", sample_record());
  const std::string command = "h5dump -p -d /state/bodies/0/masses -a /format_version '" + (dir / "c.h5").string() +
                              "' > '" + (dir / "dump").string() + "' 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << read_bytes(dir / "dump");
  const std::string dump = read_bytes(dir / "dump");
  EXPECT_THAT(dump, ::testing::HasSubstr("FLETCHER32"));
  EXPECT_THAT(dump, ::testing::HasSubstr("( 50 )"));
  EXPECT_THAT(dump, ::testing::HasSubstr("0.1, "));
  EXPECT_THAT(dump, ::testing::HasSubstr("format_version"));
  const std::string names = "h5dump -n '" + (dir / "c.h5").string() + "' > '" + (dir / "names").string() + "' 2>&1";
  ASSERT_EQ(std::system(names.c_str()), 0);
  EXPECT_THAT(read_bytes(dir / "names"), ::testing::HasSubstr("/state/scene/text"));
}

}  // namespace
}  // namespace goo
