#include "io/scene_io.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <numbers>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <vector>

#include "core/error.h"
#include "core/memory_budget.h"
#include "core/primitives.h"
#include "core/surface_geometry.h"
#include "io/atomic_file.h"
#include "io/detail/json_node.h"
#include "io/surface_mesh_io.h"
#include "io/tet_mesh_io.h"

namespace goo::io {

namespace {

using json = nlohmann::json;
using detail::Node;
using detail::optional;

constexpr double kPi = 3.14159265358979323846;

/// x' = translate + R (scale ∘ x), R = Rz Ry Rx of rotate_degrees.
struct Transform {
  Eigen::Vector3d translate = Eigen::Vector3d::Zero();
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();

  [[nodiscard]] Eigen::Vector3d apply(const Eigen::Vector3d& x) const {
    return translate + rotation * scale.cwiseProduct(x);
  }
};

/// A plane's distance from the origin, m: within ±10⁶ (a floor 10³⁰⁸ m
/// away put every vertex there and made the volume NaN).
double plane_offset(const Node& n) {
  const double d = n.number();
  if (std::abs(d) > 1e6) n.fail(fmt::format("must lie within ±1e6 m of the origin, got {}", d));
  return d;
}

/// Angles beyond this lose the precision of a turn (and 1e308° has no sine
/// worth the name).
constexpr double kLargestAngleDegrees = 1e6;

Eigen::Quaterniond rotation_of(const Node& n) {
  const Eigen::Vector3d deg = n.vec3();
  if (deg.cwiseAbs().maxCoeff() > kLargestAngleDegrees)
    n.fail(fmt::format("must lie within ±{:g} degrees (an angle, not a count of turns)", kLargestAngleDegrees));
  const Eigen::Vector3d r = deg * kPi / 180.0;
  return Eigen::Quaterniond(Eigen::AngleAxisd(r.z(), Eigen::Vector3d::UnitZ()) *
                            Eigen::AngleAxisd(r.y(), Eigen::Vector3d::UnitY()) *
                            Eigen::AngleAxisd(r.x(), Eigen::Vector3d::UnitX()));
}

Transform read_transform(Node n, bool allow_scale) {
  Transform t;
  optional(n, "translate", t.translate, [](const Node& v) { return v.vec3(); });
  optional(n, "rotate_degrees", t.rotation, rotation_of);
  if (allow_scale) {
    if (auto s = n.get("scale")) {
      if (s->value().is_array()) {
        t.scale = s->vec3();
        if (!(t.scale.minCoeff() > 0.0)) s->fail("must be positive in every axis");
      } else {
        t.scale.setConstant(s->positive());
      }
    }
  }
  n.finish();
  return t;
}

std::filesystem::path resolve(const Node& n, const std::filesystem::path& base) {
  const std::string name = n.string();
  // The system reads a file name up to its first NUL: "a\u0000b.off" would be "a".
  if (const auto nul = name.find('\0'); nul != std::string::npos)
    n.fail(fmt::format("holds a NUL character (at {}), which no file name can: a file name ends there", nul));
  if (name.empty()) n.fail("is empty; it must name a file");
  const std::filesystem::path p = name;
  const std::filesystem::path full = p.is_absolute() ? p : base / p;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(full, ec)) n.fail(fmt::format("names no readable file ('{}')", full.string()));
  return full;
}

/// What the objects read so far will need in memory to be set up, against
/// what goo may use (core/memory_budget.h): the field that makes a scene
/// too big is named before anything is allocated.
class MemoryBudget {
 public:
  /// Disabled: nothing is built (a resumed run's bodies come from its checkpoint).
  explicit MemoryBudget(bool enabled) : limit_(enabled ? static_cast<double>(memory_limit_bytes()) : 0.0), enabled_(enabled) {}
  [[nodiscard]] bool enabled() const { return enabled_; }
  void charge(const Node& field, double bytes, std::string_view what) {
    if (!enabled_) return;
    if (used_ + bytes > limit_)
      field.fail(fmt::format("gives {}, which needs about {} of memory to set up{}; goo may use {} here (the "
                             "machine's memory, or GOO_MEMORY_LIMIT)",
                             what, format_bytes(bytes),
                             used_ > 0.0 ? fmt::format(" beside the {} of the objects before it", format_bytes(used_))
                                         : std::string(),
                             format_bytes(limit_)));
    used_ += bytes;
  }

 private:
  double limit_;
  bool enabled_;
  double used_ = 0.0;
};

/// A primitive's triangle count, before it is built (core/primitives.cpp).
void charge_triangles(MemoryBudget& budget, const Node& field, double triangles) {
  if (!budget.enabled()) return;
  budget.charge(field, kSetupBytesPerTriangle * triangles, fmt::format("a surface of {:.3g} triangles", triangles));
}

/// A primitive's surface; with `build` false its fields are only checked
/// (a resumed run's body comes from its checkpoint).
TriangleMesh read_primitive(Node n, MemoryBudget& budget, bool build = true) {
  const std::string type = n.at("type").choice({"box", "sphere", "cylinder", "torus"});
  TriangleMesh mesh;
  if (type == "box") {
    const Node size = n.at("size");
    const Eigen::Vector3d s = size.vec3();
    if (!(s.minCoeff() > 0.0)) size.fail("must be positive in every axis");
    int sub = 8;
    optional(n, "subdivisions", sub, [](const Node& v) { return v.integer(1, 1000); });
    charge_triangles(budget, n.has("subdivisions") ? n.at("subdivisions") : n, 12.0 * sub * sub);
    if (build) mesh = make_box(s, sub);
  } else if (type == "sphere") {
    const double r = n.at("radius").positive();
    int seg = 32;
    optional(n, "segments", seg, [](const Node& v) { return v.integer(3, 10000); });
    charge_triangles(budget, n.has("segments") ? n.at("segments") : n, 2.0 * seg * (std::max(2, seg / 2) - 1));
    if (build) mesh = make_sphere(r, seg);
  } else if (type == "cylinder") {
    const double r = n.at("radius").positive();
    const double height = n.at("height").positive();
    int seg = 32;
    optional(n, "segments", seg, [](const Node& v) { return v.integer(3, 10000); });
    // Bands of about square quads up the side, as make_cylinder makes them.
    const double bands = std::max(1.0, std::round(height / (2.0 * r * std::sin(std::numbers::pi / seg))));
    charge_triangles(budget, n.has("segments") ? n.at("segments") : n.at("height"), 2.0 * seg * (bands + 1.0));
    if (build) mesh = make_cylinder(r, height, seg);
  } else {
    const double major = n.at("major_radius").positive();
    const Node minor_node = n.at("minor_radius");
    const double minor = minor_node.positive();
    if (!(minor < major)) minor_node.fail(fmt::format("must be below major_radius ({}), got {}", major, minor));
    int a = 48, b = 16;
    optional(n, "major_segments", a, [](const Node& v) { return v.integer(3, 10000); });
    optional(n, "minor_segments", b, [](const Node& v) { return v.integer(3, 10000); });
    const char* larger = a >= b ? "major_segments" : "minor_segments";
    charge_triangles(budget, n.has(larger) ? n.at(larger) : n, 2.0 * a * b);
    if (build) mesh = make_torus(major, minor, a, b);
  }
  n.finish();
  return mesh;
}

/// A preset, or the default material; in a scene both clamp light nodes at
/// kMinMassFraction unless the scene says otherwise.
Material scene_material(std::optional<std::string> preset) {
  if (preset) return material_preset(*preset);
  Material m;
  m.min_mass_fraction = kMinMassFraction;
  return m;
}

Material read_material(Node n) {
  if (n.value().is_string()) {
    try {
      return scene_material(n.string());
    } catch (const Error& e) {
      n.fail(e.what());
    }
  }
  n.expect_object();
  Material m = scene_material({});
  if (auto p = n.get("preset")) {
    try {
      m = scene_material(p->string());
    } catch (const Error& e) {
      p->fail(e.what());
    }
  }
  optional(n, "density", m.density, [](const Node& v) { return v.positive(); });
  optional(n, "youngs_modulus", m.youngs_modulus, [](const Node& v) { return v.positive(); });
  optional(n, "poisson_ratio", m.poisson_ratio, [](const Node& v) {
    const double x = v.number();
    if (!(x >= 0.0 && x < 0.5)) v.fail(fmt::format("must be in [0, 0.5), got {}", x));
    return x;
  });
  optional(n, "viscosity", m.viscosity, [](const Node& v) { return v.non_negative(); });
  optional(n, "yield_stress", m.yield_stress, [](const Node& v) {
    if (v.value().is_string() && v.value() == "infinity") return std::numeric_limits<double>::infinity();
    if (v.value().is_string()) v.fail("must be a number or \"infinity\"");
    return v.non_negative();
  });
  optional(n, "flow_rate", m.flow_rate, [](const Node& v) { return v.non_negative(); });
  optional(n, "hardening", m.hardening, [](const Node& v) { return v.non_negative(); });
  optional(n, "min_mass_fraction", m.min_mass_fraction, [](const Node& v) {
    const double x = v.number();
    if (!(x >= 0.0 && x <= 1.0)) v.fail(fmt::format("must be in [0, 1], got {}", x));
    return x;
  });
  optional(n, "surface_tension", m.surface_tension, [](const Node& v) { return v.non_negative(); });
  optional(n, "model", m.model, [](const Node& v) {
    return elastic_model_from_string(v.choice({"neo_hookean", "fixed_corotated", "stable_neo_hookean"}));
  });
  optional(n, "incompressible", m.incompressible, [](const Node& v) { return v.boolean(); });
  n.finish();
  validate(m, n.path(), '/');
  return m;
}

SceneObject read_object(Node n, std::size_t index, const std::filesystem::path& base, MemoryBudget& budget,
                        const SceneInputs& inputs) {
  const bool geometry = !inputs.objects_from_checkpoint;
  SceneObject o;
  o.name = fmt::format("object{}", index);
  optional(n, "name", o.name, [](const Node& v) { return v.string(); });
  const bool has_mesh = n.has("mesh"), has_primitive = n.has("primitive"), has_tets = n.has("tet_mesh");
  if (int(has_mesh) + int(has_primitive) + int(has_tets) != 1)
    n.fail("needs exactly one of 'mesh' (a surface mesh file), 'primitive' or 'tet_mesh' (a tetrahedral mesh file)");
  Transform transform;
  if (auto t = n.get("transform")) transform = read_transform(*t, true);
  if (!geometry) {
    // The body comes from the checkpoint: its fields are checked, its files not read.
    if (has_primitive) static_cast<void>(read_primitive(n.at("primitive"), budget, false));
    else static_cast<void>(n.at(has_mesh ? "mesh" : "tet_mesh").string());
  } else if (has_mesh) {
    const Node m = n.at("mesh");
    const auto path = resolve(m, base);
    try {
      o.surface = read_surface_mesh(path);
    } catch (const Error& e) {
      m.fail(fmt::format("cannot be simulated: {}", e.what()));
    }
    charge_triangles(budget, m, static_cast<double>(o.surface->num_triangles()));
  } else if (has_primitive) {
    o.surface = read_primitive(n.at("primitive"), budget);
  } else {
    const Node m = n.at("tet_mesh");
    const auto path = resolve(m, base);
    try {
      o.tet_mesh = read_tet_mesh(path);
    } catch (const Error& e) {
      m.fail(fmt::format("cannot be simulated: {}", e.what()));
    }
    const double elements = static_cast<double>(o.tet_mesh->tets.rows());
    budget.charge(m, kSetupBytesPerElement * elements, fmt::format("{:.3g} elements", elements));
  }
  if (auto k = n.get("surface_subdivisions")) {
    // Each pass splits every triangle into four at its edges' midpoints: a
    // finer surface of the same shape (W&T fig. 4's hundreds of surface
    // vertices per element).
    const int times = k->integer(0, 4);
    if (has_tets) k->fail("applies to a 'mesh' or 'primitive' surface, not to a 'tet_mesh'");
    if (o.surface) {
      charge_triangles(budget, *k, (std::pow(4.0, times) - 1.0) * static_cast<double>(o.surface->num_triangles()));
      o.surface = split_into_four(*o.surface, times);
    }
  }
  Points none;
  Points& x = o.surface ? o.surface->vertices : o.tet_mesh ? o.tet_mesh->positions : none;
  for (Eigen::Index i = 0; i < x.rows(); ++i) x.row(i) = transform.apply(x.row(i).transpose()).transpose();
  if (geometry) {
    // Double precision resolves a coordinate X to X × 2⁻⁵²: the object must
    // sit near enough the origin that this is below 10⁻⁶ of the finest
    // element it may be meshed with (1e15 m from it, the coordinates of a
    // 0.1 m cube are quantised to 0.125 m; 225 km is still fine).
    const Eigen::Vector3d extent = x.colwise().maxCoeff() - x.colwise().minCoeff();
    // The finest element a scene may ask for: 1/2000 of a surface object's
    // size (lattice_spacing's bound below), 1/100 of a tetrahedral mesh's.
    const double element = extent.maxCoeff() / (o.surface ? 2000.0 : 100.0);
    const double far = x.cwiseAbs().maxCoeff();
    const double resolution = far * std::numeric_limits<double>::epsilon();
    if (!std::isfinite(far) || !(resolution <= 1e-6 * element)) {
      const Node at = n.has("transform") ? n.at("transform") : n;
      at.fail(fmt::format("places the object {:.3g} m from the origin, where coordinates are resolved only to {:.3g} "
                          "m (over 10⁻⁶ of its finest element, {:.3g} m); move the scene nearer the origin",
                          far, resolution, element));
    }
  }
  o.material = read_material(n.at("material"));
  if (!has_tets && !geometry) {
    o.lattice_spacing = n.at("lattice_spacing").positive();
  } else if (o.surface) {
    o.lattice_spacing = n.at("lattice_spacing").positive();
    const Eigen::Vector3d extent = x.colwise().maxCoeff() - x.colwise().minCoeff();
    if (o.lattice_spacing > extent.maxCoeff())
      n.at("lattice_spacing")
          .fail(fmt::format("is larger than the object itself ({:.4g} m across)", extent.maxCoeff()));
    if (extent.maxCoeff() / o.lattice_spacing > 2000.0)
      n.at("lattice_spacing").fail("gives more than 2000 lattice cells across the object");
    // The lattice's block spans the object's box (a cell of margin each
    // way); the elements at least fill its volume (h³/12 each).
    const Eigen::Array3d block = (extent.array() / o.lattice_spacing).ceil() + 2.0;
    const double cells = block.prod();
    if (cells > kMaxLatticeCells)
      n.at("lattice_spacing")
          .fail(fmt::format("gives a lattice block of {:.3g} cells ({:.0f} × {:.0f} × {:.0f}), beyond the {:.3g} that "
                            "goo's 32-bit element indices reach; choose a larger spacing",
                            cells, block.x(), block.y(), block.z(), kMaxLatticeCells));
    const double elements = 12.0 * std::abs(surface_integrals(*o.surface).volume) / std::pow(o.lattice_spacing, 3);
    budget.charge(n.at("lattice_spacing"), kSetupBytesPerLatticeCell * cells + kSetupBytesPerElement * elements,
                  fmt::format("a lattice of {:.3g} cells and at least {:.3g} elements", cells, elements));
  } else if (n.has("lattice_spacing")) {
    n.at("lattice_spacing").fail("applies to surface objects only (a tet_mesh is simulated as it is)");
  }
  optional(n, "velocity", o.velocity, [](const Node& v) { return v.vec3(); });
  optional(n, "angular_velocity", o.angular_velocity, [](const Node& v) { return v.vec3(); });
  if (auto c = n.get("self_collisions")) {
    // true, false, or {"enabled", "thickness", "friction"}
    if (c->value().is_boolean()) {
      o.self_collisions.enabled = c->boolean();
    } else {
      SelfCollisionSettings& sc = o.self_collisions;
      optional(*c, "enabled", sc.enabled, [](const Node& v) { return v.boolean(); });
      optional(*c, "thickness", sc.thickness, [](const Node& v) { return v.positive(); });
      optional(*c, "friction", sc.friction, [](const Node& v) { return v.non_negative(); });
      const Eigen::Vector3d extent =
          geometry ? Eigen::Vector3d(x.colwise().maxCoeff() - x.colwise().minCoeff()) : Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
      if (sc.thickness >= 0.1 * extent.maxCoeff())
        c->at("thickness").fail(fmt::format("must be below a tenth of the object's size ({:.4g} m across), got {}",
                                            extent.maxCoeff(), sc.thickness));
      c->finish();
    }
  }
  if (auto p = n.get("pinned")) {
    for (std::size_t i = 0; i < p->size(); ++i) {
      Node region = p->element(i);
      Node box = region.at("box");
      const Eigen::Vector3d lo = box.at("min").vec3(), hi = box.at("max").vec3();
      if (!(lo.array() <= hi.array()).all()) box.fail("needs min ≤ max in every axis");
      box.finish();
      region.finish();
      o.pinned.push_back(PinnedRegion{Eigen::AlignedBox3d(lo, hi)});
    }
  }
  n.finish();
  return o;
}

RigidMotion::Key read_key(Node n) {
  RigidMotion::Key key;
  key.time = n.at("time").number();
  optional(n, "translate", key.translation, [](const Node& v) { return v.vec3(); });
  optional(n, "rotate_degrees", key.rotation, rotation_of);
  n.finish();
  return key;
}

Obstacle read_obstacle(Node n, std::size_t index, const std::filesystem::path& base, const SceneInputs& inputs,
                       std::map<std::string, TriangleMesh>& meshes) {
  Obstacle o;
  o.name = fmt::format("obstacle{}", index);
  optional(n, "name", o.name, [](const Node& v) { return v.string(); });
  Node shape = n.at("shape");
  const std::string type = shape.at("type").choice({"half_space", "box", "sphere", "cylinder", "mesh"});
  if (type == "half_space") {
    const Node normal = shape.at("normal");
    const Eigen::Vector3d nv = normal.vec3();
    const double largest = nv.cwiseAbs().maxCoeff();
    if (!(largest > 0.0)) normal.fail("must not be zero");
    // Scaled before normalising: [1e308, 1e308, 0] and [1e-320, 0, 0] have
    // directions though their norms overflow or underflow.
    const Eigen::Vector3d unit = (nv / largest).normalized();
    double offset = 0.0;
    optional(shape, "offset", offset, [](const Node& v) { return plane_offset(v); });
    o.shape = make_half_space(unit, offset);
  } else if (type == "box") {
    const Node size = shape.at("size");
    const Eigen::Vector3d s = size.vec3();
    if (!(s.minCoeff() > 0.0)) size.fail("must be positive in every axis");
    o.shape = make_box_shape(s / 2.0);
  } else if (type == "sphere") {
    o.shape = make_sphere_shape(shape.at("radius").positive());
  } else if (type == "cylinder") {
    const double r = shape.at("radius").positive();
    o.shape = make_cylinder_shape(r, shape.at("height").positive() / 2.0);
  } else {
    const Node path_node = shape.at("path");
    TriangleMesh mesh;
    std::string path;
    if (const auto* stored = inputs.obstacle_meshes; stored && stored->contains(path_node.path())) {
      mesh = stored->at(path_node.path());  // as read when the run began
      path = path_node.string();
    } else {
      path = resolve(path_node, base).string();
      try {
        mesh = read_surface_mesh(path);
      } catch (const Error& e) {
        path_node.fail(fmt::format("cannot be an obstacle: {}", e.what()));
      }
    }
    meshes[path_node.path()] = mesh;
    double scale = 1.0;
    optional(shape, "scale", scale, [](const Node& v) { return v.positive(); });
    mesh.vertices *= scale;
    o.shape = make_mesh_shape(mesh, path);
  }
  shape.finish();
  optional(n, "friction", o.friction, [](const Node& v) { return v.non_negative(); });
  const bool has_motion = n.has("motion");
  if (has_motion && n.has("transform")) n.at("transform").fail("cannot be given with 'motion' (its keys place the obstacle)");
  if (auto t = n.get("transform")) {
    const Transform tr = read_transform(*t, false);
    o.motion = RigidMotion({RigidMotion::Key{0.0, tr.translate, tr.rotation}});
  }
  if (auto m = n.get("motion")) {
    std::vector<RigidMotion::Key> keys;
    for (std::size_t i = 0; i < m->size(); ++i) keys.push_back(read_key(m->element(i)));
    if (keys.empty()) m->fail("needs at least one key");
    for (std::size_t i = 1; i < keys.size(); ++i)
      if (!(keys[i].time > keys[i - 1].time)) m->element(i).fail("must come later than the key before it");
    o.motion = RigidMotion(std::move(keys));
  }
  n.finish();
  return o;
}

/// The static integrator's default step: as long as it may be, so that
/// every frame is one equilibrium (a step never passes a frame's time).
constexpr double kOneSolvePerFrame = 1e9;

void read_integrator(Node n, Scene& s) {
  const std::string type = n.at("type").choice({"newmark", "backward_euler", "static"});
  if (type == "newmark") {
    s.integrator = IntegratorKind::newmark;
    NewmarkSettings& ns = s.newmark;
    optional(n, "cfl", ns.cfl, [](const Node& v) {
      const double x = v.positive();
      if (x > 1.0) v.fail(fmt::format("must be in (0, 1], got {}", x));
      return x;
    });
    optional(n, "max_strain_per_step", ns.max_strain_per_step, [](const Node& v) { return v.positive(); });
    optional(n, "max_time_step", ns.max_time_step, [](const Node& v) { return v.positive(); });
    // A fraction of the half step's impulse: at 1 or above a solve stops before it starts.
    optional(n, "cg_tolerance", ns.cg_tolerance, [](const Node& v) {
      const double x = v.number();
      if (!(x > 0.0 && x < 1.0)) v.fail(fmt::format("must be in (0, 1), got {}", x));
      return x;
    });
    optional(n, "cg_max_iterations", ns.cg_max_iterations, [](const Node& v) { return v.integer(1, 1000000); });
    optional(n, "volume_tolerance", ns.volume_tolerance, [](const Node& v) {
      const double x = v.number();
      if (!(x > 0.0 && x < 0.1)) v.fail(fmt::format("must be in (0, 0.1), got {}", x));
      return x;
    });
  } else {
    s.integrator = type == "static" ? IntegratorKind::statics : IntegratorKind::backward_euler;
    BackwardEulerSettings& bs = s.backward_euler;
    if (type == "static") {
      bs.statics = true;
      bs.time_step = kOneSolvePerFrame;
      optional(n, "gravity_ramp", bs.gravity_ramp, [](const Node& v) { return v.non_negative(); });
    }
    optional(n, "time_step", bs.time_step, [](const Node& v) { return v.positive(); });
    optional(n, "tolerance", bs.tolerance, [](const Node& v) { return v.positive(); });
    optional(n, "acceptable_tolerance", bs.acceptable_tolerance, [](const Node& v) { return v.positive(); });
    optional(n, "max_newton_iterations", bs.max_newton_iterations, [](const Node& v) { return v.integer(1, 1000); });
    optional(n, "max_halvings", bs.max_halvings, [](const Node& v) { return v.integer(0, 60); });
    optional(n, "linear_solver", bs.linear_solver, [](const Node& v) {
      const std::string c = v.choice({"automatic", "direct", "lagged_pcg"});
      return c == "direct" ? LinearSolver::direct
                           : (c == "lagged_pcg" ? LinearSolver::lagged_pcg : LinearSolver::automatic);
    });
    optional(n, "pcg_max_iterations", bs.pcg_max_iterations, [](const Node& v) { return v.integer(1, 100000); });
    optional(n, "volume_tolerance", bs.volume_tolerance, [](const Node& v) {
      const double x = v.number();
      if (!(x > 0.0 && x < 0.1)) v.fail(fmt::format("must be in (0, 0.1), got {}", x));
      return x;
    });
  }
  n.finish();
}

void read_remesh(Node n, RemeshSettings& r) {
  optional(n, "enabled", r.enabled, [](const Node& v) { return v.boolean(); });
  optional(n, "separate_parts", r.separate_parts, [](const Node& v) { return v.boolean(); });
  optional(n, "condition_growth", r.thresholds.condition_growth, [](const Node& v) {
    const double x = v.number();
    if (!(x > 1.0)) v.fail(fmt::format("must be above 1, got {}", x));
    return x;
  });
  optional(n, "min_barycentric", r.thresholds.min_barycentric, [](const Node& v) {
    const double x = v.number();
    if (!(x < 0.0)) v.fail(fmt::format("must be negative, got {}", x));
    return x;
  });
  if (auto u = n.get("upkeep")) {
    if (u->value().is_boolean()) {
      r.upkeep = u->boolean();
    } else {
      optional(*u, "enabled", r.upkeep, [](const Node& v) { return v.boolean(); });
      UpkeepSettings& us = r.upkeep_settings;
      optional(*u, "split_length", us.split_length, [](const Node& v) { return v.positive(); });
      optional(*u, "collapse_length", us.collapse_length, [](const Node& v) { return v.positive(); });
      optional(*u, "max_passes", us.max_passes, [](const Node& v) { return v.integer(1, 1000); });
      optional(*u, "flips", us.flips, [](const Node& v) { return v.boolean(); });
      if (!(us.collapse_length < 0.5 * us.split_length))
        u->fail(fmt::format("needs collapse_length ({}) below half of split_length ({}), or edges flip between the two",
                            us.collapse_length, us.split_length));
      u->finish();
    }
  }
  n.finish();
}

void read_output(Node n, OutputSettings& o) {
  optional(n, "folder", o.folder, [](const Node& v) {
    std::string s = v.string();
    if (s.empty()) v.fail("must not be empty");
    return s;
  });
  optional(n, "fps", o.fps, [](const Node& v) { return v.positive(); });
  optional(n, "frames", o.frames, [](const Node& v) { return v.integer(0, 99999); });
  if (auto f = n.get("formats")) {
    o.ply = o.obj = false;
    for (std::size_t i = 0; i < f->size(); ++i) {
      const std::string c = f->element(i).choice({"ply", "obj"});
      (c == "ply" ? o.ply : o.obj) = true;
    }
  }
  optional(n, "tet_mesh", o.tet_mesh, [](const Node& v) { return v.boolean(); });
  optional(n, "hdf5", o.hdf5, [](const Node& v) { return v.boolean(); });
  n.finish();
}

SceneCamera read_camera(Node& n) {
  SceneCamera c;
  c.position = n.at("position").vec3();
  c.target = n.at("target").vec3();
  optional(n, "up", c.up, [](const Node& v) { return v.vec3(); });
  optional(n, "fov_degrees", c.fov_degrees, [](const Node& v) {
    const double f = v.number();
    if (!(f > 0.0 && f < 180.0)) v.fail(fmt::format("must be in (0, 180) degrees, got {}", f));
    return f;
  });
  const Eigen::Vector3d view = c.target - c.position;
  if (!(view.norm() > 0.0)) n.at("target").fail("must differ from the camera's position");
  if (!(c.up.cross(view).norm() > 1e-9 * view.norm() * c.up.norm()))
    n.fail("has an 'up' direction along the line of sight (or zero): the picture has no up");
  n.finish();
  return c;
}

}  // namespace

Scene parse_scene(std::string_view text, const std::string& source, const std::filesystem::path& base_folder,
                  const SceneInputs& inputs) {
  json doc;
  // A strict reader: a key given twice in one object is refused (which of
  // the two was meant?), with its JSON path.
  struct Level {
    bool array = false;
    std::size_t index = 0;
    std::string key;
    std::set<std::string> keys;
  };
  std::vector<Level> levels;
  const auto strict = [&](int, json::parse_event_t event, json& parsed) {
    switch (event) {
      case json::parse_event_t::object_start:
      case json::parse_event_t::array_start:
        levels.push_back({event == json::parse_event_t::array_start, 0, {}, {}});
        break;
      case json::parse_event_t::key: {
        Level& level = levels.back();
        level.key = parsed.get<std::string>();
        if (!level.keys.insert(level.key).second) {
          std::string path;
          for (const Level& l : levels) path += "/" + (l.array ? std::to_string(l.index) : l.key);
          throw Error(fmt::format("{}: {} is given twice in one object (a strict reader takes neither)", source, path));
        }
        break;
      }
      case json::parse_event_t::object_end:
      case json::parse_event_t::array_end:
        levels.pop_back();
        if (!levels.empty() && levels.back().array) ++levels.back().index;
        break;
      case json::parse_event_t::value:
        if (!levels.empty() && levels.back().array) ++levels.back().index;
        break;
    }
    return true;
  };
  try {
    doc = json::parse(text, strict);
  } catch (const json::out_of_range& e) {
    // A number beyond double's range (1e309, a 400-digit integer): the
    // message quotes it; its line and column are where it first appears.
    const std::string what = e.what();
    const std::size_t open = what.find('\''), close = what.rfind('\'');
    const std::string token = open != std::string::npos && close > open ? what.substr(open + 1, close - open - 1) : "";
    const std::size_t at = token.empty() ? std::string_view::npos : text.find(token);
    std::size_t line = 1, column = 1;
    for (std::size_t i = 0; at != std::string_view::npos && i < at; ++i) {
      if (text[i] == '\n') {
        ++line;
        column = 1;
      } else {
        ++column;
      }
    }
    throw Error(fmt::format("{}:{}:{}: a number beyond the range of double precision ('{}')", source, line, column,
                            token));
  } catch (const json::parse_error& e) {
    // e.byte is one past the offending character; report line and column.
    std::size_t line = 1, column = 1;
    for (std::size_t i = 0; i + 1 < e.byte && i < text.size(); ++i) {
      if (text[i] == '\n') {
        ++line;
        column = 1;
      } else {
        ++column;
      }
    }
    throw Error(fmt::format("{}:{}:{}: not valid JSON ({})", source, line, column, e.what()));
  }
  Scene s;
  s.source = source;
  s.text = std::string(text);
  // Absolute: a checkpoint stores it, and a run resumed from another folder
  // must find the scene's meshes where the first one did.
  std::error_code absolute_error;
  const std::filesystem::path absolute = std::filesystem::absolute(base_folder, absolute_error);
  s.base_folder = (absolute_error ? base_folder : absolute.lexically_normal()).string();
  Node root(doc, "", source);
  root.expect_object();
  if (auto v = root.get("version")) {
    const int version = v->integer(0, 1000000);
    if (version != kSceneFormatVersion)
      v->fail(fmt::format("is {}; this goo reads scene format version {}", version, kSceneFormatVersion));
  }
  root.get("description");  // free text for the reader
  optional(root, "gravity", s.gravity, [](const Node& v) { return v.vec3(); });
  if (auto i = root.get("integrator")) read_integrator(*i, s);
  if (auto g = root.get("ground")) {
    HalfSpace ground;
    optional(*g, "height", ground.offset, [](const Node& v) { return plane_offset(v); });
    optional(*g, "friction", ground.friction, [](const Node& v) { return v.non_negative(); });
    g->finish();
    s.ground = ground;
  }
  if (auto st = root.get("surface_tension")) {
    optional(*st, "form", s.surface_tension.form, [](const Node& v) {
      return v.choice({"area_gradient", "paper"}) == "paper" ? SurfaceTensionForm::paper
                                                              : SurfaceTensionForm::area_gradient;
    });
    optional(*st, "smoothing", s.surface_tension.smoothing, [](const Node& v) { return v.non_negative(); });
    if (s.integrator != IntegratorKind::newmark && s.surface_tension.form == SurfaceTensionForm::paper)
      st->at("form").fail(fmt::format(
          "is 'paper', which is not the gradient of an energy; the {} integrator minimises one "
          "(use area_gradient, or the newmark integrator)",
          to_string(s.integrator)));
    st->finish();
  }
  if (auto o = root.get("obstacles"))
    for (std::size_t i = 0; i < o->size(); ++i)
      s.obstacles.push_back(read_obstacle(o->element(i), i, base_folder, inputs, s.obstacle_meshes));
  Node objects = root.at("objects");
  if (objects.size() == 0) objects.fail("needs at least one object");
  MemoryBudget budget(!inputs.objects_from_checkpoint);
  for (std::size_t i = 0; i < objects.size(); ++i)
    s.objects.push_back(read_object(objects.element(i), i, base_folder, budget, inputs));
  std::set<std::string> names;
  for (std::size_t i = 0; i < s.objects.size(); ++i)
    if (!names.insert(s.objects[i].name).second)
      objects.element(i).fail(fmt::format("repeats the object name '{}'", s.objects[i].name));
  if (s.integrator == IntegratorKind::statics)
    for (std::size_t i = 0; i < s.objects.size(); ++i) {
      // Without held nodes a body has no equilibrium under gravity (contact
      // is not part of the static solve), and an incompressible one none of
      // its own (docs/implicit.md, "Static equilibrium").
      if (s.objects[i].pinned.empty())
        objects.element(i).fail("needs a 'pinned' region with the static integrator: a body held nowhere has no equilibrium");
      if (s.objects[i].material.incompressible)
        objects.element(i).fail("is incompressible, which the static integrator does not support (use newmark or backward_euler)");
    }
  if (auto c = root.get("collisions_between_bodies")) {
    // true, false, or {"enabled", "thickness", "friction"}
    BodyCollisionSettings& bc = s.body_collisions;
    if (c->value().is_boolean()) {
      bc.enabled = c->boolean();
    } else {
      optional(*c, "enabled", bc.enabled, [](const Node& v) { return v.boolean(); });
      optional(*c, "thickness", bc.thickness, [](const Node& v) { return v.positive(); });
      optional(*c, "friction", bc.friction, [](const Node& v) { return v.non_negative(); });
      double smallest = std::numeric_limits<double>::infinity();
      for (const SceneObject& o : s.objects) {
        if (!o.surface && !o.tet_mesh) continue;  // from a checkpoint: checked when the run began
        const Points& x = o.surface ? o.surface->vertices : o.tet_mesh->positions;
        smallest = std::min(smallest, (x.colwise().maxCoeff() - x.colwise().minCoeff()).maxCoeff());
      }
      if (bc.thickness >= 0.1 * smallest)
        c->at("thickness").fail(fmt::format(
            "must be below a tenth of the smallest object's size ({:.4g} m across), got {}", smallest, bc.thickness));
      c->finish();
    }
  }
  if (auto r = root.get("remesh")) read_remesh(*r, s.remesh);
  if (auto o = root.get("output")) read_output(*o, s.output);
  if (auto c = root.get("checkpoint")) {
    optional(*c, "every_frames", s.checkpoint_every_frames, [](const Node& v) { return v.integer(0, 1000000); });
    c->finish();
  }
  if (auto l = root.get("limits")) {
    optional(*l, "max_speed", s.limits.max_speed, [](const Node& v) { return v.positive(); });
    l->finish();
  }
  if (auto c = root.get("camera")) s.camera = read_camera(*c);
  root.finish();
  return s;
}

Scene read_scene(const std::filesystem::path& path) {
  require_regular_file(path, "the scene file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("{}: cannot open the scene file", path.string()));
  std::stringstream text;
  text << in.rdbuf();
  if (in.bad()) throw Error(fmt::format("{}: cannot read the scene file", path.string()));
  return parse_scene(text.str(), path.string(), path.parent_path().empty() ? "." : path.parent_path());
}

std::string_view default_scene_text() {
  return R"({
  "version": 1,
  "description": "The built-in demo: the Stanford bunny, 75,408 triangles on about 600 elements of gooey jelly, dropped onto a ball (W&T figures 1 and 3).",
  "gravity": [0, 0, -9.81],
  "integrator": {"type": "newmark"},
  "ground": {"height": 0.0, "friction": 0.5},
  "obstacles": [
    {"name": "ball", "shape": {"type": "sphere", "radius": 0.06}, "friction": 0.3,
     "transform": {"translate": [0.03, 0, 0.06]}}
  ],
  "objects": [
    {
      "name": "bunny",
      "mesh": "bunny00.off",
      "transform": {"scale": 0.2, "rotate_degrees": [90, 0, 0], "translate": [0, 0, 0.25]},
      "material": {"preset": "gooey_jelly", "min_mass_fraction": 0.05},
      "lattice_spacing": 0.04
    }
  ],
  "output": {"fps": 24, "frames": 36, "folder": "goo-out"},
  "checkpoint": {"every_frames": 12}
}
)";
}

std::filesystem::path demo_assets_folder() {
  std::vector<std::filesystem::path> places;
  if (const char* env = std::getenv("GOO_ASSETS_DIR"); env && *env) places.emplace_back(env);
  places.emplace_back(GOO_ASSETS_DIR);  // the source tree goo was built from
  places.emplace_back(std::filesystem::current_path() / "assets");
  std::string looked;
  for (const auto& place : places) {
    std::error_code error;
    if (std::filesystem::is_regular_file(place / "bunny00.off", error)) return place;
    looked += fmt::format("{}{}", looked.empty() ? "" : ", ", place.string());
  }
  throw Error(fmt::format(
      "the built-in demo needs bunny00.off (the Stanford bunny of Debian's libcgal-demo) and found it in none of {}: "
      "run scripts/fetch-assets, or set GOO_ASSETS_DIR to a folder holding it, or give a scene",
      looked));
}

Scene demo_scene() {
  return parse_scene(default_scene_text(), "<built-in demo>", demo_assets_folder());
}

}  // namespace goo::io
