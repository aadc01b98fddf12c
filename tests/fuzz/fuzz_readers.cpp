// goo_fuzz: a mutation fuzzer over goo's readers, run as a user runs goo.
// Each case mutates a seed file (a surface mesh in every format, a scene, a
// checkpoint), hands it to the goo command, and holds goo to its promise:
// exit 0 or exit 2 with a message naming the file, nothing written on exit 2,
// no signal, no hang. A fixed seed gives the same cases everywhere; a failing
// case's file and command are kept for reproduction.
//
//   goo_fuzz [--cases N] [--seed S] [--timeout SECONDS] [--only meshes|scenes|checkpoints] [--keep DIR]
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/primitives.h"
#include "core/state_record.h"
#include "io/checkpoint.h"
#include "io/surface_mesh_io.h"
#include "tests/fuzz/mutators.h"
#include "tests/io/bad_mesh_fixtures.h"

namespace goo::fuzz {
namespace {

namespace fs = std::filesystem;

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_bytes(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

bool folder_has_files(const fs::path& folder) {
  std::error_code ec;
  if (!fs::exists(folder, ec)) return false;
  for (const auto& entry : fs::recursive_directory_iterator(folder, ec))
    if (entry.is_regular_file()) return true;
  return false;
}

struct Outcome {
  int exit_code = -1;  ///< -1: killed by a signal or by the timeout
  int signal = 0;
  bool hung = false;
  std::string err;
};

/// Runs `argv` (argv[0] the program) with stdout and stderr to files in
/// `folder`; kills its process group after `timeout` seconds.
Outcome run(const std::vector<std::string>& argv, const fs::path& folder, double timeout) {
  const fs::path out = folder / "stdout", err = folder / "stderr";
  const pid_t child = ::fork();
  if (child == 0) {
    ::setpgid(0, 0);
    const int o = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int e = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(o, 1);
    ::dup2(e, 2);
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  Outcome outcome;
  const auto start = std::chrono::steady_clock::now();
  int status = 0;
  while (true) {
    const pid_t done = ::waitpid(child, &status, WNOHANG);
    if (done == child) break;
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > timeout) {
      ::kill(-child, SIGKILL);
      ::waitpid(child, &status, 0);
      outcome.hung = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  if (!outcome.hung && WIFEXITED(status)) outcome.exit_code = WEXITSTATUS(status);
  if (!outcome.hung && WIFSIGNALED(status)) outcome.signal = WTERMSIG(status);
  outcome.err = read_bytes(err);
  return outcome;
}

// ---- seeds ----------------------------------------------------------------

struct Seed {
  std::string name;   ///< file name: its extension picks the reader
  std::string bytes;
};

std::vector<Seed> mesh_seeds(const fs::path& work) {
  std::vector<Seed> seeds;
  const TriangleMesh sphere = make_sphere(0.1, 8), box = make_box(Eigen::Vector3d(0.2, 0.1, 0.1), 2);
  int k = 0;
  for (const TriangleMesh* mesh : {&sphere, &box}) {
    for (const char* ext : {".off", ".obj", ".ply", ".stl"}) {
      for (const io::Encoding encoding : {io::Encoding::binary, io::Encoding::ascii}) {
        if (encoding == io::Encoding::ascii && (std::string(ext) == ".off" || std::string(ext) == ".obj")) continue;
        const fs::path path = work / fmt::format("seed{}{}", k++, ext);
        io::WriteOptions options;
        options.encoding = encoding;
        io::write_surface_mesh(path, *mesh, options);
        seeds.push_back({path.filename().string(), read_bytes(path)});
      }
    }
  }
  for (const test::BadMesh& bad : test::bad_meshes()) seeds.push_back({bad.name, bad.contents});
  return seeds;
}

/// Small scenes touching every reader path: primitives, a mesh file, a tet
/// mesh, obstacles, pins, both integrators, self-collisions, a camera.
std::vector<Seed> scene_seeds() {
  return {
      {"box.json", R"({"version": 1, "description": "a jelly box", "gravity": [0, 0, -9.81],
        "integrator": {"type": "newmark", "cfl": 0.5, "max_strain_per_step": 0.1, "max_time_step": 0.005},
        "ground": {"height": 0.0, "friction": 0.5},
        "surface_tension": {"form": "area_gradient", "smoothing": 0.5},
        "objects": [{"name": "jelly", "primitive": {"type": "box", "size": [0.2, 0.2, 0.2], "subdivisions": 3},
                     "transform": {"scale": 1.0, "rotate_degrees": [20, 30, 0], "translate": [0, 0, 0.3]},
                     "velocity": [0.1, 0, -1], "angular_velocity": [0, 1, 0],
                     "material": {"preset": "gooey_jelly", "min_mass_fraction": 0.05, "surface_tension": 0.01,
                                  "incompressible": true},
                     "lattice_spacing": 0.05, "self_collisions": {"enabled": true, "friction": 0.2},
                     "pinned": [{"box": {"min": [-1, -1, 0.38], "max": [1, 1, 1]}}]}],
        "remesh": {"enabled": true, "condition_growth": 3, "min_barycentric": -0.2,
                   "upkeep": {"enabled": true, "split_length": 0.5, "collapse_length": 0.05, "max_passes": 16}},
        "output": {"fps": 24, "frames": 3, "formats": ["ply", "obj"], "tet_mesh": true, "hdf5": true},
        "obstacles": [{"shape": {"type": "mesh", "path": "sphere.off", "scale": 0.5},
                       "transform": {"translate": [0.6, 0, 0]}}],
        "checkpoint": {"every_frames": 1}, "limits": {"max_speed": 100},
        "camera": {"position": [1, -1, 1], "target": [0, 0, 0.1], "fov_degrees": 40}})"},
      {"mesh.json", R"({"integrator": {"type": "backward_euler", "time_step": 0.005},
        "objects": [{"mesh": "sphere.off", "material": {"density": 1000, "youngs_modulus": 5e4, "poisson_ratio": 0.3,
                     "viscosity": 1, "yield_stress": 100, "flow_rate": 10, "hardening": 0.1,
                     "model": "stable_neo_hookean"}, "lattice_spacing": 0.04}],
        "obstacles": [{"name": "ball", "shape": {"type": "sphere", "radius": 0.1}, "friction": 0.3,
                       "transform": {"translate": [0, 0, -0.3]}},
                      {"shape": {"type": "half_space", "normal": [0, 0.1, 1], "offset": -0.5}},
                      {"shape": {"type": "box", "size": [0.5, 0.5, 0.1]},
                       "motion": [{"time": 0, "translate": [0, 0, 0.25]}, {"time": 1, "translate": [0, 0, 0.1],
                                  "rotate_degrees": [0, 0, 10]}]},
                      {"shape": {"type": "mesh", "path": "sphere.off", "scale": 0.5},
                       "transform": {"translate": [0.5, 0, 0]}}],
        "output": {"frames": 2}})"},
      {"two.json", R"({"objects": [{"name": "a", "primitive": {"type": "sphere", "radius": 0.05, "segments": 12},
                     "material": "splashing_fluid", "lattice_spacing": 0.03},
                    {"name": "b", "primitive": {"type": "torus", "major_radius": 0.08, "minor_radius": 0.03,
                     "major_segments": 12, "minor_segments": 6}, "transform": {"translate": [0, 0, 0.3]},
                     "material": "rigid_brick", "lattice_spacing": 0.04},
                    {"name": "c", "primitive": {"type": "cylinder", "radius": 0.03, "height": 0.1, "segments": 10},
                     "transform": {"translate": [0.3, 0, 0]}, "material": "viscous_ooze", "lattice_spacing": 0.03}],
        "collisions_between_bodies": {"enabled": true, "friction": 0.3},
        "output": {"frames": 2, "folder": "out"}})"},
      {"tets.json", R"({"objects": [{"tet_mesh": "beam.mesh", "material": "jiggly_gelatin",
        "transform": {"translate": [0, 0, 1]}}], "output": {"frames": 1}})"},
  };
}

/// A tetrahedral mesh in MEDIT format: one cube split into five tets.
const char* kBeamMesh =
    "MeshVersionFormatted 1\nDimension 3\nVertices\n8\n0 0 0 0\n0.1 0 0 0\n0 0.1 0 0\n0.1 0.1 0 0\n"
    "0 0 0.1 0\n0.1 0 0.1 0\n0 0.1 0.1 0\n0.1 0.1 0.1 0\nTetrahedra\n5\n1 2 4 6 0\n1 4 3 7 0\n1 6 5 7 0\n"
    "4 6 7 8 0\n1 4 6 7 0\nEnd\n";

// ---- checkpoints ----------------------------------------------------------

constexpr std::size_t kUserBlock = 512;

std::uint64_t fnv1a(std::string_view bytes) {
  std::uint64_t hash = 0xcbf29ce484222325ULL;
  for (const char c : bytes) {
    hash ^= static_cast<unsigned char>(c);
    hash *= 0x100000001b3ULL;
  }
  return hash;
}

/// The user block written again for the (mutated) bytes after it, as goo
/// writes it: the checksums hold, so the mutation reaches HDF5 and the
/// value checks.
void repair_checksum(std::string& bytes) {
  if (bytes.size() < kUserBlock) return;
  std::string header = fmt::format("goo-checkpoint\nformat_version 1\nlength {}\nfnv1a64 {:016x}\n", bytes.size(),
                                   fnv1a(std::string_view(bytes).substr(kUserBlock)));
  header.resize(kUserBlock, '\0');
  bytes.replace(0, kUserBlock, header);
}

/// One array of the record changed: a value made extreme, an id out of
/// range, a row dropped, the type swapped.
StateRecord mutate_record(const StateRecord& record, Random& random) {
  const auto& arrays = record.arrays();
  auto chosen = arrays.begin();
  std::advance(chosen, static_cast<std::ptrdiff_t>(below(random, arrays.size())));
  StateRecord out;
  for (const auto& [name, array] : arrays) {
    StateArray a = array;
    if (name == chosen->first) {
      const std::size_t n = a.size();
      switch (below(random, 5)) {
        case 0:
        case 1:
          if (a.integer && n > 0) {
            static constexpr std::int64_t kIds[] = {-1, 0, 1, 2147483647, 2147483648LL, -9223372036854775807LL - 1,
                                                    99999, 100000, 1000000000};
            a.integers[below(random, n)] = kIds[below(random, std::size(kIds))];
          } else if (n > 0) {
            static constexpr double kReals[] = {std::numeric_limits<double>::quiet_NaN(),
                                                std::numeric_limits<double>::infinity(), -1.0, 0.0, 1e300, -1e300,
                                                5e-324, 1e9, -1e-12, 1e20};
            a.reals[below(random, n)] = kReals[below(random, std::size(kReals))];
          }
          break;
        case 2:  // a row fewer
          if (!a.shape.empty() && a.shape[0] > 0) {
            const std::size_t row = n / a.shape[0];
            --a.shape[0];
            if (a.integer) a.integers.resize(a.integers.size() - row);
            else a.reals.resize(a.reals.size() - row);
          }
          break;
        case 3:  // integers as reals, or reals as integers
          if (a.integer) {
            a.integer = false;
            a.reals.assign(a.integers.begin(), a.integers.end());
            a.integers.clear();
          } else {
            a.integer = true;
            for (const double v : a.reals) a.integers.push_back(std::isfinite(v) ? static_cast<std::int64_t>(v) : 0);
            a.reals.clear();
          }
          break;
        default:  // every value scaled
          for (double& v : a.reals) v *= 1e6;
          for (std::int64_t& v : a.integers) v = v * 3 + 1;
          break;
      }
    }
    out.put_array(name, a);
  }
  for (const auto& [name, value] : record.strings()) {
    std::string v = value;
    if (below(random, 8) == 0 && !v.empty()) mutate_bytes(v, random);  // the stored scene, say
    out.put_string(name, v);
  }
  return out;
}

// ---- the harness ----------------------------------------------------------

struct Options {
  int cases = 300;
  std::uint64_t seed = 1;
  double timeout = 20.0;
  std::string only;
  fs::path keep = fs::temp_directory_path() / "goo_fuzz_failures";
  std::string goo = GOO_EXECUTABLE;
};

struct Harness {
  Options options;
  fs::path work;
  std::vector<Seed> meshes, scenes;
  std::string checkpoint_bytes;
  StateRecord checkpoint_record;
  int failures = 0, accepted = 0, refused = 0;

  /// Holds goo to its promise for one command; keeps the case when it breaks it.
  void check(int index, const std::string& kind, const fs::path& input, const std::vector<std::string>& argv,
             const fs::path& out) {
    const fs::path folder = input.parent_path();
    const Outcome r = run(argv, folder, options.timeout);
    std::string broken;
    if (r.hung) broken = fmt::format("no answer within {} s", options.timeout);
    else if (r.signal != 0) broken = fmt::format("killed by signal {}", r.signal);
    else if (r.exit_code != 0 && r.exit_code != 2) broken = fmt::format("exit code {}", r.exit_code);
    else if (r.exit_code == 2 && r.err.find(input.filename().string()) == std::string::npos)
      broken = "exit 2 without naming the file";
    else if (r.exit_code == 2 && !out.empty() && folder_has_files(out)) broken = "exit 2 after writing output";
    if (broken.empty()) {
      (r.exit_code == 0 ? accepted : refused) += 1;
      return;
    }
    ++failures;
    fs::create_directories(options.keep);
    const fs::path kept = options.keep / fmt::format("case{}_{}", index, input.filename().string());
    fs::copy_file(input, kept, fs::copy_options::overwrite_existing);
    std::string command;
    for (const std::string& a : argv) command += (command.empty() ? "" : " ") + a;
    std::cerr << fmt::format("goo_fuzz: case {} ({}): {}\n  input kept as {}\n  command: {}\n  stderr: {}\n", index,
                             kind, broken, kept.string(), command, r.err.substr(0, 600));
  }

  void mesh_case(int index, Random& random) {
    const Seed& seed = meshes[below(random, meshes.size())];
    std::string bytes = seed.bytes;
    for (std::size_t k = 0, n = 1 + below(random, 3); k < n; ++k) mutate_bytes(bytes, random);
    const fs::path folder = work / fmt::format("case{}", index);
    fs::create_directories(folder);
    const fs::path input = folder / fmt::format("mutant{}", fs::path(seed.name).extension().string());
    write_bytes(input, bytes);
    std::vector<std::string> argv{options.goo, "info", input.string()};
    if (below(random, 3) == 0) argv.emplace_back("--json");
    check(index, "mesh " + seed.name, input, argv, {});
  }

  void scene_case(int index, Random& random) {
    const Seed& seed = scenes[below(random, scenes.size())];
    std::string text = seed.bytes;
    const std::size_t n = 1 + below(random, 3);
    if (below(random, 2) == 0) {
      nlohmann::json document = nlohmann::json::parse(text);
      for (std::size_t k = 0; k < n; ++k) mutate_json(document, random);
      text = document.dump(1);
    } else {
      for (std::size_t k = 0; k < n; ++k) mutate_bytes(text, random);
    }
    const fs::path folder = work / fmt::format("case{}", index);
    fs::create_directories(folder);
    io::write_surface_mesh(folder / "sphere.off", make_sphere(0.1, 10));
    write_bytes(folder / "beam.mesh", kBeamMesh);
    const fs::path input = folder / seed.name;
    write_bytes(input, text);
    const fs::path out = folder / "out";
    check(index, "scene " + seed.name, input,
          {options.goo, "run", input.string(), "--frames", "0", "--out", out.string(), "--quiet", "--threads", "1"},
          out);
  }

  void checkpoint_case(int index, Random& random) {
    const fs::path folder = work / fmt::format("case{}", index);
    fs::create_directories(folder / "run" / "checkpoints");
    const fs::path input = folder / "run" / "checkpoints" / "frame_00001.h5";
    const std::size_t how = below(random, 3);
    if (how == 2) {
      io::write_checkpoint(input, mutate_record(checkpoint_record, random));
    } else {
      std::string bytes = checkpoint_bytes;
      for (std::size_t k = 0, n = 1 + below(random, 3); k < n; ++k) mutate_bytes(bytes, random);
      if (how == 1) repair_checksum(bytes);
      write_bytes(input, bytes);
    }
    check(index, "checkpoint info", input, {options.goo, "info", input.string()}, {});
    const fs::path out = folder / "resumed";
    check(index, "checkpoint resume", input,
          {options.goo, "run", "--resume", input.string(), "--frames", "1", "--out", out.string(), "--quiet",
           "--threads", "1"},
          out);
  }

  int run_all() {
    work = fs::temp_directory_path() / fmt::format("goo_fuzz_{}_{}", ::getpid(), options.seed);
    fs::create_directories(work);
    meshes = mesh_seeds(work);
    scenes = scene_seeds();
    {
      // The checkpoint seed: a small run's own, at frame 1.
      const fs::path scene = work / "seed.json";
      write_bytes(scene, scenes[0].bytes);
      io::write_surface_mesh(work / "sphere.off", make_sphere(0.1, 10));
      const Outcome made = run({options.goo, "run", scene.string(), "--frames", "1", "--out", (work / "seed").string(),
                                "--quiet", "--threads", "1"},
                               work, 10 * options.timeout);
      if (made.exit_code != 0) {
        std::cerr << "goo_fuzz: the seed run failed: " << made.err << "\n";
        return 1;
      }
      checkpoint_bytes = read_bytes(work / "seed/checkpoints/frame_00001.h5");
      checkpoint_record = io::read_checkpoint(work / "seed/checkpoints/frame_00001.h5");
    }
    for (std::size_t k = 0; k < scenes.size(); ++k) {
      // Every seed is accepted unmutated: the mutants start from valid input.
      const fs::path folder = work / fmt::format("seed_scene{}", k);
      fs::create_directories(folder);
      io::write_surface_mesh(folder / "sphere.off", make_sphere(0.1, 10));
      write_bytes(folder / "beam.mesh", kBeamMesh);
      write_bytes(folder / scenes[k].name, scenes[k].bytes);
      const Outcome made = run({options.goo, "run", (folder / scenes[k].name).string(), "--frames", "0", "--out",
                                (folder / "out").string(), "--quiet", "--threads", "1"},
                               folder, 10 * options.timeout);
      if (made.exit_code != 0) {
        std::cerr << "goo_fuzz: the seed scene " << scenes[k].name << " is refused: " << made.err << "\n";
        return 1;
      }
    }
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < options.cases; ++i) {
      // Each case its own stream: a case reproduces alone from (seed, i).
      const std::uint64_t stream = options.seed * std::uint64_t{0x9e3779b97f4a7c15} + static_cast<unsigned>(i);
      Random random(stream);
      const int kind = i % 3;
      if (kind == 0 && (options.only.empty() || options.only == "meshes")) mesh_case(i, random);
      if (kind == 1 && (options.only.empty() || options.only == "scenes")) scene_case(i, random);
      if (kind == 2 && (options.only.empty() || options.only == "checkpoints")) checkpoint_case(i, random);
      std::error_code ec;
      fs::remove_all(work / fmt::format("case{}", i), ec);  // a failing case's input is kept apart
    }
    std::error_code ec;
    fs::remove_all(work, ec);
    std::cout << fmt::format("goo_fuzz: {} cases (seed {}) in {:.1f} s: {} accepted, {} refused, {} broke a promise{}\n",
                             options.cases, options.seed,
                             std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), accepted,
                             refused, failures, failures ? fmt::format(" (kept in {})", options.keep.string()) : "");
    return failures == 0 ? 0 : 1;
  }
};

}  // namespace
}  // namespace goo::fuzz

int main(int argc, char** argv) {
  goo::fuzz::Options options;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--cases" && has_value) options.cases = std::atoi(argv[++i]);
    else if (a == "--seed" && has_value) options.seed = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--timeout" && has_value) options.timeout = std::atof(argv[++i]);
    else if (a == "--only" && has_value) options.only = argv[++i];
    else if (a == "--keep" && has_value) options.keep = argv[++i];
    else if (a == "--goo" && has_value) options.goo = argv[++i];
    else {
      std::cerr << "usage: goo_fuzz [--cases N] [--seed S] [--timeout SECONDS] [--only meshes|scenes|checkpoints] "
                   "[--keep DIR] [--goo PATH]\n";
      return 2;
    }
  }
  // Set-up bounded for every case: a mutated lattice spacing that fits in
  // memory but takes minutes to mesh must not read as a hang.
  ::setenv("GOO_MEMORY_LIMIT", "256M", 1);
  try {
    goo::fuzz::Harness harness{options, {}, {}, {}, {}, {}, 0, 0, 0};
    return harness.run_all();
  } catch (const std::exception& e) {
    std::cerr << "goo_fuzz: " << e.what() << "\n";
    return 1;
  }
}
