// Scene files: every shipped scene parses; every kind of bad scene is refused
// with the JSON path or the file named.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>

#include "core/surface_geometry.h"
#include "io/scene_io.h"
#include "io/surface_mesh_io.h"
#include "tests/common/test_common.h"
#include "tests/io/bad_mesh_fixtures.h"

namespace goo {
namespace {

const std::filesystem::path kScenes = std::filesystem::path(GOO_SOURCE_DIR) / "scenes";

Scene parse(const std::string& text) { return io::parse_scene(text, "test.json", kScenes); }

/// A minimal valid scene with `object` as its one object.
std::string with_object(const std::string& object, const std::string& extra = "") {
  return fmt::format(R"({{"version": 1, {} "objects": [{}]}})", extra, object);
}

const std::string kCube =
    R"({"primitive": {"type": "box", "size": [0.2, 0.2, 0.2]}, "material": "jiggly_gelatin", "lattice_spacing": 0.05})";

TEST(Scene, EveryShippedSceneParses) {
  int count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kScenes)) {
    if (entry.path().extension() != ".json") continue;
    SCOPED_TRACE(entry.path().string());
    const Scene scene = io::read_scene(entry.path());
    EXPECT_FALSE(scene.objects.empty());
    EXPECT_EQ(scene.text.empty(), false);
    ++count;
  }
  EXPECT_GE(count, 8);
}

TEST(Scene, TheBuiltInDemoIsTheDetailedBunnyOfGooeyJellyDroppedOntoABall) {
  // What the method is for: a fine surface (the 75,408-triangle bunny) on a
  // lattice coarse beside it, flowing; a ball under it, the floor below.
  const Scene s = io::demo_scene();
  ASSERT_EQ(s.objects.size(), 1u);
  const SceneObject& bunny = s.objects[0];
  const Material jelly = material_preset("gooey_jelly");
  EXPECT_EQ(bunny.material.youngs_modulus, jelly.youngs_modulus);
  EXPECT_EQ(bunny.material.yield_stress, jelly.yield_stress);
  ASSERT_TRUE(bunny.surface.has_value());
  EXPECT_EQ(bunny.surface->num_triangles(), 75408);
  // The bunny as read from the asset, scaled by 0.2: the volume scales by 0.2³.
  const double volume = surface_integrals(io::read_surface_mesh(test::asset("bunny00.off"))).volume;
  EXPECT_NEAR(surface_integrals(*bunny.surface).volume, 0.008 * volume, 1e-12 * volume);
  const SurfaceIntegrals integrals = surface_integrals(*bunny.surface);
  const double edge = std::sqrt(4.0 * integrals.area / std::sqrt(3.0) / double(bunny.surface->num_triangles()));
  EXPECT_GT(bunny.lattice_spacing, 10.0 * edge);  // many triangles to an element
  ASSERT_EQ(s.obstacles.size(), 1u);
  const double lowest = bunny.surface->vertices.col(2).minCoeff();
  const Eigen::AlignedBox3d ball = s.obstacles[0].bounds(0.0);
  EXPECT_LT(ball.max().z(), lowest);  // the bunny starts above the ball...
  EXPECT_GT(ball.max().z(), 0.0);     // ...which stands on the floor
  EXPECT_GE(ball.min().z(), 0.0);
  ASSERT_TRUE(s.ground.has_value());
  EXPECT_EQ(s.output.fps, 24.0);
  EXPECT_GE(s.output.frames / s.output.fps, 1.0);  // the fall, the impact and the slump
}

TEST(Scene, TheBuiltInDemoReadsItsBunnyFromGooAssetsDirFirst) {
  test::TempDir dir;
  std::filesystem::copy_file(test::asset("bunny00.off"), dir / "bunny00.off");
  const char* before = std::getenv("GOO_ASSETS_DIR");
  const std::optional<std::string> saved = before ? std::optional<std::string>(before) : std::nullopt;
  ASSERT_EQ(setenv("GOO_ASSETS_DIR", dir.path().c_str(), 1), 0);
  const std::filesystem::path found = io::demo_assets_folder();
  unsetenv("GOO_ASSETS_DIR");
  const std::filesystem::path otherwise = io::demo_assets_folder();
  if (saved) setenv("GOO_ASSETS_DIR", saved->c_str(), 1);
  EXPECT_EQ(found, dir.path());
  EXPECT_EQ(otherwise, std::filesystem::path(GOO_ASSETS_DIR));  // the source tree's, filled by scripts/fetch-assets
}

TEST(Scene, PresetsSpanRigidToFluidAndFieldsOverrideThem) {
  const auto& names = material_preset_names();
  ASSERT_EQ(names.size(), 5u);
  // From rigid to fluid: stiffness falls, and the fluid ones flow.
  EXPECT_GT(material_preset(names.front()).youngs_modulus, material_preset(names.back()).youngs_modulus);
  EXPECT_FALSE(material_preset("rigid_brick").plastic());
  EXPECT_TRUE(material_preset("splashing_fluid").plastic());
  const Scene s = parse(with_object(
      R"({"primitive": {"type": "box", "size": [0.2, 0.2, 0.2]}, "material": {"preset": "gooey_jelly", "viscosity": 3, "yield_stress": "infinity"}, "lattice_spacing": 0.05})"));
  EXPECT_EQ(s.objects[0].material.viscosity, 3.0);
  EXPECT_FALSE(s.objects[0].material.plastic());
  EXPECT_EQ(s.objects[0].material.youngs_modulus, material_preset("gooey_jelly").youngs_modulus);
}

TEST(Scene, TransformScalesRotatesThenTranslates) {
  const Scene s = parse(with_object(
      R"({"primitive": {"type": "box", "size": [1, 2, 3]}, "material": "rigid_brick", "lattice_spacing": 0.5,
          "transform": {"scale": 0.5, "rotate_degrees": [0, 0, 90], "translate": [1, 2, 3]}})"));
  const Eigen::AlignedBox3d box = bounding_box(s.objects[0].surface->vertices);
  // size (0.5, 1, 1.5) turned 90° about z: (1, 0.5, 1.5), centred at (1, 2, 3).
  EXPECT_TRUE(test::matrices_near(box.sizes(), Eigen::Vector3d(1.0, 0.5, 1.5), 1e-12));
  EXPECT_TRUE(test::matrices_near(box.center(), Eigen::Vector3d(1, 2, 3), 1e-12));
}

TEST(Scene, SurfaceSubdivisionsSplitEveryTriangleIntoFourPerPassBeforeTheTransform) {
  const std::string object =
      R"({{"primitive": {{"type": "box", "size": [1, 2, 3], "subdivisions": 2}}, "surface_subdivisions": {},
          "material": "rigid_brick", "lattice_spacing": 0.5, "transform": {{"scale": 0.5, "translate": [1, 2, 3]}}}})";
  const Scene coarse = parse(with_object(fmt::format(fmt::runtime(object), 0)));
  const Scene fine = parse(with_object(fmt::format(fmt::runtime(object), 2)));
  EXPECT_EQ(coarse.objects[0].surface->num_triangles(), 48);
  EXPECT_EQ(fine.objects[0].surface->num_triangles(), 16 * 48);
  // The same placed shape: the box's corners, its volume.
  const Eigen::AlignedBox3d a = bounding_box(coarse.objects[0].surface->vertices);
  const Eigen::AlignedBox3d b = bounding_box(fine.objects[0].surface->vertices);
  EXPECT_TRUE(a.min() == b.min() && a.max() == b.max());
  EXPECT_NEAR(surface_integrals(*fine.objects[0].surface).volume, 0.75, 1e-13);
}

TEST(Scene, IntegratorAndItsSettingsAreChosenPerScene) {
  const Scene n = parse(with_object(kCube));
  EXPECT_EQ(n.integrator, IntegratorKind::newmark);
  const Scene b = parse(with_object(
      kCube, R"("integrator": {"type": "backward_euler", "time_step": 0.02, "linear_solver": "direct"},)"));
  EXPECT_EQ(b.integrator, IntegratorKind::backward_euler);
  EXPECT_EQ(b.backward_euler.time_step, 0.02);
  EXPECT_EQ(b.backward_euler.linear_solver, LinearSolver::direct);
  // Surface tension is an energy for backward Euler; its smoothing applies to either integrator.
  const Scene t = parse(with_object(
      R"({"primitive": {"type": "box", "size": [1, 1, 1]}, "material": {"surface_tension": 0.07}, "lattice_spacing": 0.5})",
      R"("integrator": {"type": "backward_euler"}, "surface_tension": {"smoothing": 0.5},)"));
  EXPECT_EQ(t.objects[0].material.surface_tension, 0.07);
  EXPECT_EQ(t.surface_tension.smoothing, 0.5);
}

// The static integrator: backward Euler's settings with statics on, one
// equilibrium per frame unless a time_step says otherwise; every object must
// be held somewhere and be compressible, and its own key is checked.
TEST(Scene, TheStaticIntegratorNeedsHeldCompressibleBodies) {
  const std::string held =
      R"({"primitive": {"type": "box", "size": [1, 0.1, 0.1]}, "material": {"youngs_modulus": 1e6},
          "lattice_spacing": 0.05, "pinned": [{"box": {"min": [-1, -1, -1], "max": [0.01, 1, 1]}}]})";
  const Scene s = parse(with_object(held, R"("integrator": {"type": "static", "gravity_ramp": 2},)"));
  EXPECT_EQ(s.integrator, IntegratorKind::statics);
  EXPECT_EQ(to_string(s.integrator), "static");
  EXPECT_TRUE(s.backward_euler.statics);
  EXPECT_EQ(s.backward_euler.gravity_ramp, 2.0);
  EXPECT_GT(s.backward_euler.time_step, 1e6);  // a step never passes a frame: one equilibrium each
  EXPECT_EQ(parse(with_object(held, R"("integrator": {"type": "static", "time_step": 0.1},)")).backward_euler.time_step,
            0.1);
  EXPECT_FALSE(parse(with_object(held, R"("integrator": {"type": "backward_euler"},)")).backward_euler.statics);
  EXPECT_TRUE(test::throws_error_containing(
      [&] { parse(with_object(held, R"("integrator": {"type": "static", "gravity_ramp": -1},)")); },
      "test.json: /integrator/gravity_ramp must be non-negative"));
  EXPECT_TRUE(test::throws_error_containing(
      [&] { parse(with_object(held, R"("integrator": {"type": "backward_euler", "gravity_ramp": 1},)")); },
      "/integrator/gravity_ramp is not a known key here"));
  const std::string loose =
      R"({"primitive": {"type": "box", "size": [1, 0.1, 0.1]}, "material": {"youngs_modulus": 1e6}, "lattice_spacing": 0.05})";
  EXPECT_TRUE(test::throws_error_containing(
      [&] { parse(with_object(loose, R"("integrator": {"type": "static"},)")); },
      "test.json: /objects/0 needs a 'pinned' region with the static integrator"));
  const std::string incompressible =
      R"({"primitive": {"type": "box", "size": [1, 0.1, 0.1]}, "material": "jiggly_gelatin",
          "lattice_spacing": 0.05, "pinned": [{"box": {"min": [-1, -1, -1], "max": [0.01, 1, 1]}}]})";
  EXPECT_TRUE(test::throws_error_containing(
      [&] { parse(with_object(incompressible, R"("integrator": {"type": "static"},)")); },
      "/objects/0 is incompressible, which the static integrator does not support"));
}

TEST(Scene, PresetsAreIncompressibleAndTheKeySwitchesItPerObject) {
  for (const std::string& name : material_preset_names()) {
    EXPECT_TRUE(material_preset(name).incompressible) << name;
    EXPECT_EQ(material_preset(name).min_mass_fraction, kMinMassFraction) << name;  // its one home
  }
  EXPECT_FALSE(Material{}.incompressible);  // a material given only by its constants is not
  // ... but in a scene it has the presets' lightest node, unless the scene says otherwise.
  EXPECT_EQ(parse(with_object(R"({"primitive": {"type": "box", "size": [0.2, 0.2, 0.2]}, "material": {"youngs_modulus": 1e4}, "lattice_spacing": 0.05})"))
                .objects[0]
                .material.min_mass_fraction,
            kMinMassFraction);
  const auto cube_with = [](const std::string& material) {
    return with_object(fmt::format(
        R"({{"primitive": {{"type": "box", "size": [0.2, 0.2, 0.2]}}, "material": {}, "lattice_spacing": 0.05}})",
        material));
  };
  EXPECT_TRUE(parse(cube_with(R"("splashing_fluid")")).objects[0].material.incompressible);
  EXPECT_FALSE(parse(cube_with(R"({"preset": "splashing_fluid", "incompressible": false})")).objects[0].material.incompressible);
  EXPECT_TRUE(parse(cube_with(R"({"youngs_modulus": 1e4, "incompressible": true})")).objects[0].material.incompressible);
  EXPECT_FALSE(parse(cube_with(R"({"youngs_modulus": 1e4})")).objects[0].material.incompressible);
  EXPECT_TRUE(test::throws_error_containing([&] { parse(cube_with(R"({"incompressible": 1})")); },
                                            "/objects/0/material/incompressible must be true or false"));
  const auto with_integrator = [&](const std::string& integrator) {
    return with_object(kCube, fmt::format(R"("integrator": {},)", integrator));
  };
  EXPECT_EQ(parse(with_integrator(R"({"type": "newmark", "volume_tolerance": 1e-6})")).newmark.volume_tolerance, 1e-6);
  EXPECT_EQ(parse(with_integrator(R"({"type": "backward_euler", "volume_tolerance": 1e-3})")).backward_euler.volume_tolerance,
            1e-3);
  EXPECT_TRUE(test::throws_error_containing(
      [&] { parse(with_integrator(R"({"type": "newmark", "volume_tolerance": 0})")); },
      "/integrator/volume_tolerance must be in (0, 0.1), got 0"));
  // The damping solves' tolerance is a fraction of the half step's impulse.
  EXPECT_EQ(parse(with_integrator(R"({"type": "newmark", "cg_tolerance": 0.5})")).newmark.cg_tolerance, 0.5);
  for (const auto& [bad, shown] : {std::pair{"1", "1"}, {"2.5", "2.5"}, {"0", "0"}, {"-1e-6", "-1e-06"}})
    EXPECT_TRUE(test::throws_error_containing(
        [&] { parse(with_integrator(fmt::format(R"({{"type": "newmark", "cg_tolerance": {}}})", bad))); },
        fmt::format("/integrator/cg_tolerance must be in (0, 1), got {}", shown)))
        << bad;
}

TEST(Scene, SelfCollisionsAreOnUnlessSwitchedOff) {
  const auto cube_with = [](const std::string& value) {
    return with_object(fmt::format(
        R"({{"primitive": {{"type": "box", "size": [0.2, 0.2, 0.2]}}, "material": "jiggly_gelatin", "lattice_spacing": 0.05, "self_collisions": {}}})",
        value));
  };
  const Scene on = parse(with_object(kCube));
  EXPECT_TRUE(on.objects[0].self_collisions.enabled);
  EXPECT_EQ(on.objects[0].self_collisions.thickness, 0.0);  // the default: a fraction of the lattice spacing
  EXPECT_FALSE(parse(cube_with("false")).objects[0].self_collisions.enabled);
  const Scene set = parse(cube_with(R"({"thickness": 0.001, "friction": 0.4})"));
  EXPECT_TRUE(set.objects[0].self_collisions.enabled);
  EXPECT_EQ(set.objects[0].self_collisions.thickness, 0.001);
  EXPECT_EQ(set.objects[0].self_collisions.friction, 0.4);
  EXPECT_FALSE(parse(cube_with(R"({"enabled": false})")).objects[0].self_collisions.enabled);
  // Refused, naming the field.
  EXPECT_TRUE(test::throws_error_containing([&] { parse(cube_with(R"({"thickness": -1})")); },
                                            "/objects/0/self_collisions/thickness must be positive"));
  EXPECT_TRUE(test::throws_error_containing([&] { parse(cube_with(R"({"thickness": 0.05})")); },
                                            "/objects/0/self_collisions/thickness must be below a tenth of the object's size"));
  EXPECT_TRUE(test::throws_error_containing([&] { parse(cube_with(R"({"friction": -0.1})")); },
                                            "/objects/0/self_collisions/friction must be"));
  EXPECT_TRUE(test::throws_error_containing([&] { parse(cube_with(R"({"thicknes": 0.001})")); },
                                            "/objects/0/self_collisions/thicknes is not a known key"));
  EXPECT_TRUE(test::throws_error_containing([&] { parse(cube_with(R"("yes")")); },
                                            "/objects/0/self_collisions must be an object"));
}

TEST(Scene, SeparatingTheMaterialsPartsIsOnUnlessSwitchedOff) {
  EXPECT_TRUE(parse(with_object(kCube)).remesh.separate_parts);
  EXPECT_FALSE(parse(with_object(kCube, R"("remesh": {"separate_parts": false},)")).remesh.separate_parts);
  EXPECT_TRUE(parse(with_object(kCube, R"("remesh": {"separate_parts": true},)")).remesh.separate_parts);
  EXPECT_TRUE(test::throws_error_containing([&] { parse(with_object(kCube, R"("remesh": {"separate_parts": 1},)")); },
                                            "/remesh/separate_parts must be"));
}

TEST(Scene, BodiesCollideWithEachOtherUnlessSwitchedOff) {
  const auto with = [](const std::string& value) {
    return with_object(kCube, fmt::format(R"("collisions_between_bodies": {},)", value));
  };
  const Scene plain = parse(with_object(kCube));
  EXPECT_TRUE(plain.body_collisions.enabled);
  EXPECT_EQ(plain.body_collisions.thickness, 0.0);  // the default: the bodies' own
  EXPECT_EQ(plain.body_collisions.friction, 0.0);
  EXPECT_FALSE(parse(with("false")).body_collisions.enabled);
  const Scene set = parse(with(R"({"thickness": 0.001, "friction": 0.8})"));
  EXPECT_TRUE(set.body_collisions.enabled);
  EXPECT_EQ(set.body_collisions.thickness, 0.001);
  EXPECT_EQ(set.body_collisions.friction, 0.8);
  EXPECT_FALSE(parse(with(R"({"enabled": false})")).body_collisions.enabled);
  EXPECT_TRUE(test::throws_error_containing([&] { parse(with(R"({"thickness": 0})")); },
                                            "/collisions_between_bodies/thickness must be positive"));
  EXPECT_TRUE(test::throws_error_containing(
      [&] { parse(with(R"({"thickness": 0.03})")); },
      "/collisions_between_bodies/thickness must be below a tenth of the smallest object's size (0.2 m across)"));
  EXPECT_TRUE(test::throws_error_containing([&] { parse(with(R"({"friction": -1})")); },
                                            "/collisions_between_bodies/friction must be"));
  EXPECT_TRUE(test::throws_error_containing([&] { parse(with(R"({"frction": 1})")); },
                                            "/collisions_between_bodies/frction is not a known key"));
  EXPECT_TRUE(test::throws_error_containing([&] { parse(with("1")); }, "/collisions_between_bodies must be an object"));
}

TEST(Scene, TransformsDoublePrecisionCannotHoldAreRefusedNamingTheTransform) {
  const auto cube_at = [](const std::string& transform) {
    return with_object(fmt::format(
        R"({{"primitive": {{"type": "box", "size": [0.2, 0.2, 0.2]}}, "material": "jiggly_gelatin", "lattice_spacing": 0.05, "transform": {}}})",
        transform));
  };
  // 100 km away resolves the 0.2 m cube to 1.5e-11 m: fine.
  EXPECT_EQ(parse(cube_at(R"({"translate": [1e5, 0, 0]})")).objects.size(), 1u);
  EXPECT_TRUE(test::throws_error_containing([&] { parse(cube_at(R"({"translate": [1e15, 0, 0]})")); },
                                            "/objects/0/transform places the object 1e+15 m from the origin"));
  EXPECT_TRUE(test::throws_error_containing([&] { parse(cube_at(R"({"translate": [0, -1e308, 0]})")); },
                                            "/objects/0/transform places the object"));
  // Scaled up, it stays centred and resolved: its lattice is what fails.
  EXPECT_TRUE(test::throws_error_containing([&] { parse(cube_at(R"({"scale": 1e300})")); },
                                            "/objects/0/lattice_spacing gives more than 2000 lattice cells"));
  EXPECT_TRUE(test::throws_error_containing([&] { parse(cube_at(R"({"rotate_degrees": [0, 1e308, 0]})")); },
                                            "/objects/0/transform/rotate_degrees must lie within ±1e+06 degrees"));
  EXPECT_EQ(parse(cube_at(R"({"rotate_degrees": [720, -45, 3600]})")).objects.size(), 1u);
  // Planes: offsets within ±1e6 m, normals of any length with a direction.
  EXPECT_TRUE(test::throws_error_containing(
      [&] { parse(with_object(kCube, R"("ground": {"height": 1e308},)")); },
      "/ground/height must lie within ±1e6 m of the origin"));
  const auto plane = [](const std::string& shape) {
    return with_object(kCube, fmt::format(R"("obstacles": [{{"shape": {}}}],)", shape));
  };
  EXPECT_TRUE(test::throws_error_containing(
      [&] { parse(plane(R"({"type": "half_space", "normal": [0, 0, 1], "offset": -1e300})")); },
      "/obstacles/0/shape/offset must lie within ±1e6 m"));
  for (const auto& [normal, unit] : {std::pair{std::string("[0, 1e308, 1e308]"), Eigen::Vector3d(0, 1, 1).normalized()},
                                     std::pair{std::string("[0, 0, 1e-320]"), Eigen::Vector3d(0, 0, 1)}}) {
    const Scene s = parse(plane(R"({"type": "half_space", "normal": )" + normal + "}"));
    ASSERT_EQ(s.obstacles.size(), 1u);
    // One metre along the normal from the plane through the origin.
    const SignedDistance d = s.obstacles[0].shape->signed_distance(unit);
    EXPECT_NEAR(d.distance, 1.0, 1e-15) << normal;
    EXPECT_TRUE(test::matrices_near(d.normal, unit, 1e-15)) << normal;
  }
}

TEST(Scene, ACameraIsForPicturesAndChecked) {
  EXPECT_FALSE(parse(with_object(kCube)).camera.has_value());
  const Scene s = parse(with_object(kCube, R"("camera": {"position": [1, -2, 1], "target": [0, 0, 0.1], "fov_degrees": 40},)"));
  ASSERT_TRUE(s.camera.has_value());
  EXPECT_EQ(s.camera->position, Eigen::Vector3d(1, -2, 1));
  EXPECT_EQ(s.camera->target, Eigen::Vector3d(0, 0, 0.1));
  EXPECT_EQ(s.camera->up, Eigen::Vector3d::UnitZ());
  EXPECT_EQ(s.camera->fov_degrees, 40.0);
  const auto refused = [&](const std::string& camera, const std::string& message) {
    return test::throws_error_containing([&] { parse(with_object(kCube, "\"camera\": " + camera + ",")); }, message);
  };
  EXPECT_TRUE(refused(R"({"target": [0, 0, 0]})", "/camera needs the key 'position'"));
  EXPECT_TRUE(refused(R"({"position": [0, 0, 1], "target": [0, 0, 1]})", "/camera/target must differ"));
  EXPECT_TRUE(refused(R"({"position": [0, 0, 1], "target": [0, 0, 0]})", "/camera has an 'up' direction along the line of sight"));
  EXPECT_TRUE(refused(R"({"position": [1, 0, 1], "target": [0, 0, 0], "fov_degrees": 180})", "/camera/fov_degrees must be in (0, 180)"));
  EXPECT_TRUE(refused(R"({"position": [1, 0, 1], "target": [0, 0, 0], "zoom": 2})", "/camera/zoom is not a known key"));
}

struct BadScene {
  std::string name;
  std::string text;
  std::string expected;  // in the message
};

void PrintTo(const BadScene& b, std::ostream* os) { *os << b.name; }

class BadScenes : public ::testing::TestWithParam<BadScene> {};

TEST_P(BadScenes, AreRefusedNamingTheJsonPath) {
  EXPECT_TRUE(test::throws_error_containing([&] { parse(GetParam().text); }, GetParam().expected));
}

INSTANTIATE_TEST_SUITE_P(
    Scene, BadScenes,
    ::testing::Values(
        BadScene{"not_json", "{\"objects\": [", "test.json:1:"},
        BadScene{"unknown_top_key", with_object(kCube, R"("gravty": [0, 0, -9.81],)"), "/gravty is not a known key"},
        BadScene{"unknown_nested_key",
                 with_object(
                     R"({"primitive": {"type": "box", "size": [1, 1, 1]}, "material": {"densty": 5}, "lattice_spacing": 0.5})"),
                 "/objects/0/material/densty is not a known key"},
        BadScene{"wrong_type", with_object(kCube, R"("gravity": "down",)"), "/gravity must be an array of 3 numbers"},
        BadScene{"wrong_type_number",
                 with_object(
                     R"({"primitive": {"type": "box", "size": [1, 1, 1]}, "material": {"density": "heavy"}, "lattice_spacing": 0.5})"),
                 "/objects/0/material/density must be a number, got a string"},
        BadScene{"negative_density",
                 with_object(
                     R"({"primitive": {"type": "box", "size": [1, 1, 1]}, "material": {"density": -1}, "lattice_spacing": 0.5})"),
                 "/objects/0/material/density must be positive, got -1"},
        BadScene{"poisson_half",
                 with_object(
                     R"({"primitive": {"type": "box", "size": [1, 1, 1]}, "material": {"poisson_ratio": 0.5}, "lattice_spacing": 0.5})"),
                 "/objects/0/material/poisson_ratio must be in [0, 0.5), got 0.5"},
        BadScene{"unknown_preset",
                 with_object(R"({"primitive": {"type": "box", "size": [1, 1, 1]}, "material": "custard", "lattice_spacing": 0.5})"),
                 "/objects/0/material unknown material preset 'custard'"},
        BadScene{"no_geometry", with_object(R"({"material": "rigid_brick", "lattice_spacing": 0.5})"),
                 "/objects/0 needs exactly one of 'mesh'"},
        BadScene{"two_geometries",
                 with_object(
                     R"({"primitive": {"type": "box", "size": [1, 1, 1]}, "mesh": "x.off", "material": "rigid_brick", "lattice_spacing": 0.5})"),
                 "/objects/0 needs exactly one of"},
        BadScene{"too_many_surface_subdivisions",
                 with_object(
                     R"({"primitive": {"type": "box", "size": [1, 1, 1]}, "surface_subdivisions": 5, "material": "rigid_brick", "lattice_spacing": 0.5})"),
                 "/objects/0/surface_subdivisions must be an integer in [0, 4], got 5"},
        BadScene{"surface_subdivisions_of_a_tet_mesh",
                 with_object(R"({"tet_mesh": "beam.mesh", "surface_subdivisions": 1, "material": "rigid_brick"})"),
                 "/objects/0/surface_subdivisions applies to a 'mesh' or 'primitive' surface, not to a 'tet_mesh'"},
        BadScene{"no_spacing", with_object(R"({"primitive": {"type": "box", "size": [1, 1, 1]}, "material": "rigid_brick"})"),
                 "/objects/0 needs the key 'lattice_spacing'"},
        BadScene{"spacing_too_big",
                 with_object(R"({"primitive": {"type": "box", "size": [1, 1, 1]}, "material": "rigid_brick", "lattice_spacing": 2})"),
                 "/objects/0/lattice_spacing is larger than the object"},
        BadScene{"no_objects", R"({"objects": []})", "/objects needs at least one object"},
        BadScene{"unknown_integrator", with_object(kCube, R"("integrator": {"type": "rk4"},)"),
                 "/integrator/type must be one of newmark, backward_euler, static, got 'rk4'"},
        BadScene{"newmark_key_on_implicit", with_object(kCube, R"("integrator": {"type": "backward_euler", "cfl": 0.3},)"),
                 "/integrator/cfl is not a known key"},
        BadScene{"negative_fps", with_object(kCube, R"("output": {"fps": -24},)"), "/output/fps must be positive"},
        BadScene{"fractional_frames", with_object(kCube, R"("output": {"frames": 2.5},)"),
                 "/output/frames must be an integer"},
        BadScene{"unknown_format", with_object(kCube, R"("output": {"formats": ["fbx"]},)"),
                 "/output/formats/0 must be one of ply, obj"},
        BadScene{"future_version", R"({"version": 2, "objects": []})", "/version is 2"},
        BadScene{"duplicate_key", with_object(kCube, R"("gravity": [0, 0, -9.81], "gravity": [0, 0, -1],)"),
                 "test.json: /gravity is given twice in one object"},
        BadScene{"duplicate_nested_key",
                 fmt::format(R"({{"objects": [{}, {}]}})", kCube,
                             R"({"primitive": {"type": "box", "size": [1, 1, 1]}, "material": {"density": 5, "density": 6}, "lattice_spacing": 0.5})"),
                 "test.json: /objects/1/material/density is given twice"},
        BadScene{"number_overflow", with_object(kCube, R"("gravity": [0, 0, 1e309],)"),
                 "test.json:1:34: a number beyond the range of double precision ('1e309')"},
        BadScene{"huge_integer", with_object(kCube, R"("output": {"frames": 18446744073709551615},)"),
                 "/output/frames must be an integer in [0, 99999], got 18446744073709551615"},
        BadScene{"keys_out_of_order",
                 with_object(kCube,
                             R"("obstacles": [{"shape": {"type": "sphere", "radius": 1}, "motion": [{"time": 1}, {"time": 0.5}]}],)"),
                 "/obstacles/0/motion/1 must come later"},
        BadScene{"zero_normal",
                 with_object(kCube, R"("obstacles": [{"shape": {"type": "half_space", "normal": [0, 0, 0]}}],)"),
                 "/obstacles/0/shape/normal must not be zero"},
        BadScene{"implicit_with_paper_tension",
                 with_object(
                     R"({"primitive": {"type": "box", "size": [1, 1, 1]}, "material": {"surface_tension": 0.07}, "lattice_spacing": 0.5})",
                     R"("integrator": {"type": "backward_euler"}, "surface_tension": {"form": "paper"},)"),
                 "/surface_tension/form is 'paper', which is not the gradient of an energy"},
        BadScene{"repeated_names", fmt::format(R"({{"objects": [{}, {}]}})",
                                               R"({"name": "a", "primitive": {"type": "box", "size": [1, 1, 1]}, "material": "rigid_brick", "lattice_spacing": 0.5})",
                                               R"({"name": "a", "primitive": {"type": "box", "size": [1, 1, 1]}, "material": "rigid_brick", "lattice_spacing": 0.5})"),
                 "/objects/1 repeats the object name 'a'"},
        BadScene{"missing_mesh_file",
                 with_object(R"({"mesh": "no/such/bunny.off", "material": "rigid_brick", "lattice_spacing": 0.5})"),
                 "/objects/0/mesh names no readable file"},
        BadScene{"nul_in_mesh_path",
                 with_object(R"({"mesh": "bunny\u0000.off", "material": "rigid_brick", "lattice_spacing": 0.5})"),
                 "/objects/0/mesh holds a NUL character (at 5)"},
        BadScene{"empty_mesh_path", with_object(R"({"mesh": "", "material": "rigid_brick", "lattice_spacing": 0.5})"),
                 "/objects/0/mesh is empty"},
        BadScene{"nul_in_obstacle_path",
                 with_object(kCube, R"("obstacles": [{"shape": {"type": "mesh", "path": "\u0000"}}],)"),
                 "/obstacles/0/shape/path holds a NUL character (at 0)"},
        BadScene{"tet_spacing",
                 with_object(R"({"tet_mesh": "beam.mesh", "material": "rigid_brick", "lattice_spacing": 0.5})"),
                 "/objects/0/lattice_spacing applies to surface objects only"}),
    [](const ::testing::TestParamInfo<BadScene>& param_info) { return param_info.param.name; });

TEST(Scene, AnInvalidMeshFileIsRefusedNamingTheFile) {
  test::TempDir dir;
  // An open surface (one face of the tetrahedron missing).
  dir.write("open.off", test::off_tetrahedron(test::kTetVertices, "3 0 2 1\n3 0 1 3\n3 0 3 2\n", "OFF\n4 3 0\n"));
  const std::string text =
      with_object(R"({"mesh": "open.off", "material": "rigid_brick", "lattice_spacing": 0.1})");
  EXPECT_TRUE(test::throws_error_containing([&] { io::parse_scene(text, "s.json", dir.path()); }, "open.off"));
  EXPECT_TRUE(test::throws_error_containing([&] { io::read_scene(dir / "none.json"); }, "none.json: cannot open"));
}

}  // namespace
}  // namespace goo
