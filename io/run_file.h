#pragma once
// The run as one HDF5 file with an XDMF sidecar that ParaView opens as an
// animation (docs/output-format.md):
//   run.h5   /frames/NNNNN/surface_vertices  (#V×3 doubles)
//            /frames/NNNNN/surface_triangles (#T×3 int32)
//            /frames/NNNNN/surface_bodies    (#T×1 int32: each triangle's body)
//            /frames/NNNNN/tet_positions, tet_elements (when tets are kept)
//            each frame group with attribute time (s)
//   run.xdmf a temporal collection of one grid per frame pointing into run.h5
#include <filesystem>
#include <cstdint>
#include <optional>
#include <span>

#include "core/tet_mesh.h"
#include "core/triangle_mesh.h"

namespace goo::io {

class RunFile {
 public:
  /// Opens (or creates) `folder`/run.h5. When continuing a run at
  /// `first_frame`, frames from it on are dropped (they are written again);
  /// a damaged file from an earlier run is refused (goo::Error), never
  /// replaced: it holds that run's frames. Failures to write throw
  /// goo::WriteError.
  RunFile(const std::filesystem::path& folder, int first_frame);
  ~RunFile();
  RunFile(const RunFile&) = delete;
  RunFile& operator=(const RunFile&) = delete;

  /// Appends frame `frame` at time t, flushes, and rewrites run.xdmf (with
  /// `face_body`, each triangle's body: a cell field "body" in ParaView).
  void write_frame(int frame, double time, const TriangleMesh& surface, const TetMesh* tets = nullptr,
                   std::span<const std::int32_t> face_body = {});

 private:
  void write_xdmf() const;
  std::filesystem::path folder_;
  long long file_ = -1;  // hid_t
  struct Frame {
    int frame;
    double time;
    long long vertices, triangles, nodes, tets;
    bool bodies;
  };
  std::vector<Frame> frames_;
};

/// Writes a tetrahedral mesh as a binary legacy VTK unstructured grid
/// (ParaView, VisIt), atomically.
void write_tet_mesh_vtk(const std::filesystem::path& path, const TetMesh& mesh);
/// Reads a mesh write_tet_mesh_vtk wrote (goo render's wireframe). Throws
/// goo::Error naming the file for anything else, or a truncated file.
TetMesh read_tet_mesh_vtk(const std::filesystem::path& path);

}  // namespace goo::io
