// Extreme but representable parameters: simulated as the physics says, or
// stopped with a diagnosis (exit 3), or refused naming the field (exit 2);
// never a silently wrong result with exit 0.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "io/surface_mesh_io.h"
#include "tests/app/run_goo.h"

namespace goo {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string quoted(const fs::path& p) { return fmt::format("'{}'", p.string()); }

/// A gooey-jelly box with `material` fields and scene `extra` keys, no floor.
std::string box_scene(const std::string& material, const std::string& extra = "") {
  return fmt::format(R"({{{}
    "objects": [{{"primitive": {{"type": "box", "size": [0.2, 0.2, 0.2], "subdivisions": 4}},
                 "material": {{"preset": "gooey_jelly", "min_mass_fraction": 0.05{}}}, "lattice_spacing": 0.05}}],
    "output": {{"fps": 24, "frames": 2}}, "checkpoint": {{"every_frames": 0}}}})",
                     extra, material);
}

double mean_z(const fs::path& ply) {
  return io::read_surface_mesh(ply).vertices.col(2).mean();
}

TEST(ExtremeValues, ABodyOfDensity1e200FallsFreelyUnderGravity) {
  // Its squared right-hand side overflowed the damping solve, which was
  // then skipped: the body hung in the air with exit 0. A stress-free body
  // falls as a point: z̄(t) = z̄₀ − g t²/2 (Newmark integrates constant
  // acceleration exactly).
  test::TempDir dir;
  for (const char* density : {"1e200", "1e3"}) {
    SCOPED_TRACE(density);
    dir.write("s.json", box_scene(fmt::format(R"(, "density": {})", density)));
    const fs::path out = dir / fmt::format("out{}", density);
    const CommandResult run = goo(fmt::format("run {} --out {} --quiet --threads 1", quoted(dir / "s.json"), quoted(out)));
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const double z0 = mean_z(out / "frames/frame_00000.ply"), z2 = mean_z(out / "frames/frame_00002.ply");
    const double t = 2.0 / 24.0, fall = 0.5 * 9.81 * t * t;  // 3.4 cm
    EXPECT_NEAR(z0 - z2, fall, 1e-9 * fall);
  }
}

TEST(ExtremeValues, GravityOf1e200StopsWithADiagnosis) {
  test::TempDir dir;
  dir.write("s.json", box_scene("", R"("gravity": [0, 0, -1e200],)"));
  const CommandResult run = goo(fmt::format("run {} --out {} --quiet", quoted(dir / "s.json"), quoted(dir / "out")));
  EXPECT_EQ(run.exit_code, 3) << run.err;
  EXPECT_THAT(run.err, HasSubstr("above limits.max_speed"));
  EXPECT_THAT(run.err, ::testing::Not(HasSubstr("inf m/s")));  // the speed itself, not its overflowed square
  const auto summary = nlohmann::json::parse(slurp(dir / "out/summary.json"));
  EXPECT_EQ(summary["status"], "failed");
}

TEST(ExtremeValues, ABodyScaledByTwoToThe300MovesBitForBitAsUnscaled) {
  // Density, moduli, viscosity and yield stress all times 2³⁰⁰ (or 2⁻³⁰⁰):
  // every force scales with the masses, and a power of two scales exactly,
  // so the frames are the same bytes. Near the 1e100 Pa bound (E = 4e94),
  // nothing overflows.
  test::TempDir dir;
  auto scaled = [](double s) {
    return fmt::format(R"(, "density": {:.17g}, "youngs_modulus": {:.17g}, "viscosity": {:.17g}, "yield_stress": {:.17g})",
                       1000.0 * s, 2e4 * s, 10.0 * s, 400.0 * s);
  };
  const std::string floor = R"("ground": {"height": 0.0, "friction": 0.5},)";
  std::string frames[3];
  const double scales[3] = {1.0, std::ldexp(1.0, 300), std::ldexp(1.0, -300)};
  for (int k = 0; k < 3; ++k) {
    std::string scene = box_scene(scaled(scales[k]), floor);
    scene.replace(scene.find("\"frames\": 2"), 11, "\"frames\": 6");
    dir.write("s.json", scene);
    const fs::path out = dir / fmt::format("out{}", k);
    const CommandResult run = goo(fmt::format("run {} --out {} --quiet --threads 1", quoted(dir / "s.json"), quoted(out)));
    ASSERT_EQ(run.exit_code, 0) << run.err;
    frames[k] = slurp(out / "frames/frame_00006.ply");
  }
  EXPECT_TRUE(frames[1] == frames[0]);
  EXPECT_TRUE(frames[2] == frames[0]);
}

TEST(ExtremeValues, StressesBeyondWhatDoublePrecisionCanSquareAreRefused) {
  test::TempDir dir;
  for (const char* field : {"youngs_modulus", "viscosity", "yield_stress", "surface_tension"}) {
    SCOPED_TRACE(field);
    dir.write("s.json", box_scene(fmt::format(R"(, "{}": 1e101)", field)));
    const CommandResult run = goo(fmt::format("run {} --out {}", quoted(dir / "s.json"), quoted(dir / "out")));
    EXPECT_EQ(run.exit_code, 2);
    EXPECT_THAT(run.err, HasSubstr(fmt::format("/objects/0/material/{} must be at most 1e100", field)));
    EXPECT_FALSE(fs::exists(dir / "out"));
  }
}

}  // namespace
}  // namespace goo
