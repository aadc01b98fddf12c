#include "app/info_command.h"

#include <fmt/format.h>
#include <fmt/ostream.h>

#include <nlohmann/json.hpp>
#include <fstream>
#include <ostream>

#include "app/checkpoint_errors.h"
#include "core/error.h"
#include "core/surface_check.h"
#include "io/atomic_file.h"
#include "io/checkpoint.h"
#include "io/surface_mesh_io.h"
#include "solvers/checkpoint_schema.h"

namespace goo::app {
namespace {

std::string yes_no(bool b) {
  return b ? "yes" : "no";
}

nlohmann::json to_json(const std::filesystem::path& path, const SurfaceReport& r) {
  nlohmann::json j;
  j["file"] = path.string();
  j["format"] = std::string(io::to_string(io::mesh_format_of(path)));
  j["vertices"] = r.num_vertices;
  j["triangles"] = r.num_triangles;
  j["edges"] = r.num_edges;
  if (!r.bounds.isEmpty()) {
    j["bounding_box"] = {{"min", {r.bounds.min().x(), r.bounds.min().y(), r.bounds.min().z()}},
                         {"max", {r.bounds.max().x(), r.bounds.max().y(), r.bounds.max().z()}}};
  }
  if (r.topology_valid) {
    j["area"] = r.area;
    j["volume"] = std::abs(r.volume);
    j["inside_out"] = r.volume < 0.0;
    j["centroid"] = {r.centroid.x(), r.centroid.y(), r.centroid.z()};
    j["euler_characteristic"] = r.euler_characteristic();
    j["components"] = r.components;
    j["boundary_edges"] = r.boundary_edges;
    j["nonmanifold_edges"] = r.nonmanifold_edges;
    j["nonmanifold_vertices"] = r.nonmanifold_vertices;
    j["misoriented_triangles"] = r.misoriented_triangles;
  }
  j["closed"] = r.closed();
  j["manifold"] = r.manifold();
  j["consistently_oriented"] = r.consistently_oriented();
  j["simulable"] = !r.first_defect.has_value();
  if (r.first_defect) j["defect"] = *r.first_defect;
  return j;
}

void print_text(std::ostream& out, const std::filesystem::path& path, const SurfaceReport& r) {
  auto row = [&](std::string_view key, const std::string& value) { fmt::print(out, "{:<15}{}\n", key, value); };
  row("file", fmt::format("{} ({})", path.string(), io::to_string(io::mesh_format_of(path))));
  row("vertices", std::to_string(r.num_vertices));
  row("triangles", std::to_string(r.num_triangles));
  if (!r.bounds.isEmpty()) {
    const Eigen::Vector3d lo = r.bounds.min(), hi = r.bounds.max(), size = hi - lo;
    row("bounding box", fmt::format("[{:.6g}, {:.6g}, {:.6g}] to [{:.6g}, {:.6g}, {:.6g}]", lo.x(), lo.y(), lo.z(),
                                    hi.x(), hi.y(), hi.z()));
    row("size", fmt::format("{:.6g} x {:.6g} x {:.6g}", size.x(), size.y(), size.z()));
  }
  if (!r.topology_valid) return;
  row("edges", std::to_string(r.num_edges));
  row("area", fmt::format("{:.10g}", r.area));
  row("volume",
      fmt::format("{:.10g}{}", std::abs(r.volume), r.volume < 0.0 ? " (inside-out: goo flips it on load)" : ""));
  row("centroid", fmt::format("({:.10g}, {:.10g}, {:.10g})", r.centroid.x(), r.centroid.y(), r.centroid.z()));
  std::string euler = std::to_string(r.euler_characteristic());
  if (r.components == 1 && r.manifold() && r.closed() && r.orientable) {
    euler += fmt::format(" (genus {})", (2 - r.euler_characteristic()) / 2);
  }
  row("euler char.", euler);
  row("components", std::to_string(r.components));
  row("closed", r.closed() ? "yes" : fmt::format("no ({} boundary edges)", r.boundary_edges));
  std::string manifold = yes_no(r.manifold());
  if (!r.manifold()) {
    manifold +=
        fmt::format(" ({} non-manifold edges, {} non-manifold vertices)", r.nonmanifold_edges, r.nonmanifold_vertices);
  }
  row("manifold", manifold);
  std::string oriented = yes_no(r.consistently_oriented());
  if (!r.orientable)
    oriented += " (not orientable)";
  else if (r.misoriented_triangles > 0) {
    oriented +=
        fmt::format(" ({} flipped triangle{})", r.misoriented_triangles, r.misoriented_triangles == 1 ? "" : "s");
  }
  row("oriented", oriented);
  row("simulable", yes_no(!r.first_defect));
}

bool is_checkpoint(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::string magic(14, '\0');
  in.read(magic.data(), static_cast<std::streamsize>(magic.size()));
  return in && magic == "goo-checkpoint";
}

int describe_checkpoint(const std::filesystem::path& path, const StateRecord& r, bool json, std::ostream& out);

/// goo info CHECKPOINT: time, frame, bodies and their counts.
int checkpoint_info(const std::filesystem::path& path, bool json, std::ostream& out) {
  const StateRecord r = io::read_checkpoint(path);
  return reading_checkpoint(path.string(), "", [&] { return describe_checkpoint(path, r, json, out); });
}

int describe_checkpoint(const std::filesystem::path& path, const StateRecord& r, bool json, std::ostream& out) {
  nlohmann::json j;
  j["file"] = path.string();
  j["kind"] = "checkpoint";
  j["format_version"] = io::kCheckpointFormatVersion;
  const checkpoint::Clock clock = checkpoint::get_clock(r);
  const checkpoint::RunFields run = checkpoint::get_run(r);
  const std::string& scene = checkpoint::get_scene_source(r);
  j["time"] = clock.time;
  j["frame"] = run.frame;
  j["steps"] = clock.steps;
  j["remeshes"] = clock.remeshes;
  j["last_time_step"] = clock.last_time_step;
  j["scene"] = scene;
  const auto count = checkpoint::get_body_count(r);
  j["bodies"] = nlohmann::json::array();
  for (std::int64_t i = 0; i < count; ++i) {
    const checkpoint::StoredBody b = checkpoint::get_body(r, static_cast<std::size_t>(i));
    j["bodies"].push_back({{"name", b.name},
                           {"nodes", b.body.positions.rows()},
                           {"elements", b.body.tets.rows()},
                           {"surface_vertices", b.body.embedding.parent.size()},
                           {"surface_triangles", b.body.surface_triangles.rows()},
                           {"mass", b.body.masses.sum()},
                           {"lattice", b.lattice}});
  }
  if (json) {
    out << j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) << '\n';  // file names need not be UTF-8
    return 0;
  }
  auto row = [&](std::string_view key, const std::string& value) { fmt::print(out, "{:<15}{}\n", key, value); };
  row("file", fmt::format("{} (goo checkpoint, format version {})", path.string(), io::kCheckpointFormatVersion));
  row("scene", scene);
  row("time", fmt::format("{:.6g} s", clock.time));
  row("frame", std::to_string(run.frame));
  row("steps", std::to_string(clock.steps));
  row("re-meshes", std::to_string(clock.remeshes));
  for (const auto& b : j["bodies"]) {
    row("body", fmt::format("{}: {} nodes, {} elements, {} surface triangles, mass {:.6g} kg", b["name"].get<std::string>(),
                            b["nodes"].get<long>(), b["elements"].get<long>(), b["surface_triangles"].get<long>(),
                            b["mass"].get<double>()));
  }
  return 0;
}

}  // namespace

int run_info(const std::filesystem::path& mesh_path, bool json, std::ostream& out) {
  io::require_regular_file(mesh_path, "a mesh file or checkpoint");
  if (is_checkpoint(mesh_path)) return checkpoint_info(mesh_path, json, out);
  io::ReadOptions options;
  options.validate = false;  // report on what is there; judge below
  const TriangleMesh mesh = io::read_surface_mesh(mesh_path, options);
  const SurfaceReport report = analyze_surface(mesh);
  if (json) {
    out << to_json(mesh_path, report).dump(2, ' ', false, nlohmann::json::error_handler_t::replace) << '\n';
  } else {
    print_text(out, mesh_path, report);
  }
  if (report.first_defect) throw Error(fmt::format("{}: {}", mesh_path.string(), *report.first_defect));
  return 0;
}

}  // namespace goo::app
