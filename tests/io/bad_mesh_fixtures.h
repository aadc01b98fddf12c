#pragma once
// Broken mesh files, each with the words its error message must contain.
// Shared by the reader tests and the `goo info` tests.
#include <cstdint>
#include <cstring>
#include <limits>
#include <ostream>
#include <string>
#include <vector>

namespace goo::test {

struct BadMesh {
  std::string name;      // file name (its extension picks the format)
  std::string contents;  // bytes
  std::string expected;  // substring of the error message
};

inline void PrintTo(const BadMesh& bad, std::ostream* os) {
  *os << bad.name;
}

inline std::string off_tetrahedron(const std::string& vertices, const std::string& faces,
                                   const std::string& header = "OFF\n4 4 0\n") {
  return header + vertices + faces;
}

inline const std::string kTetVertices = "0 0 0\n1 0 0\n0 1 0\n0 0 1\n";
inline const std::string kTetFaces = "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";

/// Binary little-endian PLY of the unit tetrahedron; `tweak` edits the body.
inline std::string binary_ply_tetrahedron(float nan_at_vertex1 = 0.0f, std::int32_t last_index = 3) {
  std::string s =
      "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
      "property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n";
  const float v[4][3] = {{0, 0, 0}, {1, nan_at_vertex1, 0}, {0, 1, 0}, {0, 0, 1}};
  s.append(reinterpret_cast<const char*>(v), sizeof v);
  const std::int32_t f[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, last_index}};
  for (const auto& t : f) {
    s.push_back(3);
    s.append(reinterpret_cast<const char*>(t), sizeof t);
  }
  return s;
}

/// Binary STL of the unit tetrahedron.
inline std::string binary_stl_tetrahedron() {
  std::string s(80, '\0');
  s.replace(0, 9, "goo tests");
  const std::uint32_t n = 4;
  s.append(reinterpret_cast<const char*>(&n), 4);
  const float p[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  const int f[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  for (const auto& t : f) {
    const float normal[3] = {0, 0, 0};
    s.append(reinterpret_cast<const char*>(normal), 12);
    for (const int k : t) s.append(reinterpret_cast<const char*>(p[k]), 12);
    s.append(2, '\0');
  }
  return s;
}

inline std::vector<BadMesh> bad_meshes() {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::string stl = binary_stl_tetrahedron();
  const std::string ply = binary_ply_tetrahedron();
  return {
      {"open.off", off_tetrahedron(kTetVertices, "3 0 2 1\n3 0 1 3\n3 0 3 2\n", "OFF\n4 3 0\n"), "not closed"},
      {"nonmanifold.off",
       "OFF\n6 8 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n0 -1 0\n0 0 -1\n" + kTetFaces + "3 0 4 1\n3 0 1 5\n3 0 5 4\n3 1 4 5\n",
       "edge (0, 1) is shared by 4 triangles"},
      {"flipped.off", off_tetrahedron(kTetVertices, "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 3 2\n"), "triangle 3 is flipped"},
      {"nan.off", off_tetrahedron("0 0 0\nnan 0 0\n0 1 0\n0 0 1\n", kTetFaces),
       "line 4: vertex 1: the coordinate 'nan' is not finite"},
      {"nan.ply", binary_ply_tetrahedron(nan), "vertex 1 has a non-finite coordinate"},
      {"nan.obj", "v 0 0 0\nv 1 0 0\nv 0 inf 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
       "line 3: vertex 2: the coordinate 'inf' is not finite"},
      {"text.off", off_tetrahedron("0 0 0\n1 zero 0\n0 1 0\n0 0 1\n", kTetFaces),
       "line 4: vertex 1: 'zero' is not a number"},
      {"range.off", off_tetrahedron(kTetVertices, "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 9\n"),
       "line 10: face 3 references vertex 9, but the file declares 4 vertices"},
      {"range.ply", binary_ply_tetrahedron(0.0f, 9), "face 3 references vertex 9"},
      {"range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 12\n",
       "line 8: face references vertex 12, but 4 vertices are defined before it"},
      {"empty.off", "", "the file is empty"},
      {"empty.ply", "", "the file is empty"},
      {"empty.stl", "", "the file is empty"},
      {"empty.obj", "", "the file is empty"},
      {"truncated.ply", ply.substr(0, ply.size() - 7), "truncated: it ends inside face 3 of the 4"},
      {"truncated.stl", stl.substr(0, stl.size() - 30),
       "truncated: its header declares 4 triangles (284 bytes) but the file has 254 bytes"},
      {"short.stl", stl.substr(0, 40), "too short for a binary STL"},
      {"truncated.off", off_tetrahedron(kTetVertices, "3 0 2 1\n3 0 1 3\n"), "ends after 2 of the 4 faces"},
      {"header.off", off_tetrahedron(kTetVertices, kTetFaces, "OFX\n4 4 0\n"),
       "line 1: wrong header: expected 'OFF', found 'OFX'"},
      {"header.ply", "plx\n" + ply.substr(4), "line 1: wrong header: expected 'ply', found 'plx'"},
      {"noend.ply", "ply\nformat ascii 1.0\nelement vertex 4\n", "no 'end_header'"},
      {"noindices.ply",
       "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 4\nproperty list uchar int corners\nend_header\n" + kTetVertices + kTetFaces,
       "the PLY 'face' element has no 'vertex_indices' list"},
      {"realindices.ply",
       "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 4\nproperty list uchar float vertex_indices\nend_header\n" + kTetVertices + kTetFaces,
       "list 'vertex_indices' holds float values, not vertex indices"},
      {"floatrange.ply",
       "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 4\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1e39 0 0\n0 1 0\n0 0 1\n" +
           kTetFaces,
       "line 11: vertex 1: '1e39' is out of range for a float"},
      {"ascii.stl", "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 nan\n",
       "facet 0: the coordinate 'nan' is not finite"},
      {"mesh.xyz", "0 0 0\n", "unknown surface mesh format '.xyz'"},
  };
}

}  // namespace goo::test
