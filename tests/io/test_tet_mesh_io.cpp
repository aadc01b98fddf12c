#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fmt/format.h>

#include "core/error.h"
#include "core/tet_mesh.h"
#include "io/tet_mesh_io.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

using ::testing::HasSubstr;

/// The box mesh as TetGen text, ids from `base`, with attributes, boundary
/// markers and comments the reader must skip.
void write_tetgen(const test::TempDir& dir, const TetMesh& mesh, int base) {
  std::string node = fmt::format("# nodes\n{} 3 1 1\n", mesh.num_nodes());
  for (Index n = 0; n < mesh.num_nodes(); ++n)
    node += fmt::format("{} {:.17g} {:.17g} {:.17g} 0.5 1\n", n + base, mesh.positions(n, 0), mesh.positions(n, 1),
                        mesh.positions(n, 2));
  std::string ele = fmt::format("{} 4 1\n", mesh.num_elements());
  for (Index e = 0; e < mesh.num_elements(); ++e)
    ele += fmt::format("{} {} {} {} {} 7  # region\n", e + base, mesh.tets(e, 0) + base, mesh.tets(e, 1) + base,
                       mesh.tets(e, 2) + base, mesh.tets(e, 3) + base);
  dir.write("box.node", node);
  dir.write("box.ele", ele);
}

std::string medit_text(const TetMesh& mesh) {
  std::string s = "MeshVersionFormatted 2\nDimension\n3\n\nVertices\n" + std::to_string(mesh.num_nodes()) + "\n";
  for (Index n = 0; n < mesh.num_nodes(); ++n)
    s += fmt::format("{:.17g} {:.17g} {:.17g} 0\n", mesh.positions(n, 0), mesh.positions(n, 1), mesh.positions(n, 2));
  s += "Triangles\n1\n1 2 3 0\nTetrahedra\n" + std::to_string(mesh.num_elements()) + "\n";
  for (Index e = 0; e < mesh.num_elements(); ++e)
    s += fmt::format("{} {} {} {} 1\n", mesh.tets(e, 0) + 1, mesh.tets(e, 1) + 1, mesh.tets(e, 2) + 1,
                     mesh.tets(e, 3) + 1);
  return s + "End\n";
}

TEST(ReadTetMesh, TetGenWithZeroOrOneBasedIdsReadsTheSameMesh) {
  const TetMesh box = make_box_tets({1.0, 0.5, 0.25}, {3, 2, 2});
  for (const int base : {0, 1}) {
    test::TempDir dir;
    write_tetgen(dir, box, base);
    for (const char* name : {"box.node", "box.ele"}) {
      const TetMesh mesh = io::read_tet_mesh(dir / name);
      EXPECT_TRUE(mesh.positions == box.positions);
      EXPECT_TRUE(mesh.tets == box.tets);
    }
  }
}

TEST(ReadTetMesh, MeditSkipsOtherSectionsAndReorientsNegativeElements) {
  TetMesh box = make_box_tets(Eigen::Vector3d::Ones(), Eigen::Vector3i::Constant(2));
  std::swap(box.tets(5, 1), box.tets(5, 2));  // one negatively oriented element
  test::TempDir dir;
  const TetMesh mesh = io::read_tet_mesh(dir.write("box.mesh", medit_text(box)));
  EXPECT_EQ(mesh.num_elements(), box.num_elements());
  for (Index e = 0; e < mesh.num_elements(); ++e) EXPECT_GT(signed_volume(mesh.positions, mesh.tets, e), 0.0);
}

struct BadTetFile {
  std::string name, contents, expected;
};

TEST(ReadTetMesh, BadInputIsNamedWithFileAndLine) {
  const std::string nodes = "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n";
  const std::vector<BadTetFile> cases = {
      {"range.mesh", "Dimension 3\nVertices\n4\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\nTetrahedra\n1\n1 2 3 9 0\nEnd\n",
       "line 10: tetrahedron 0 references node 9, but the mesh has 4 nodes"},
      {"nan.mesh", "Dimension 3\nVertices\n4\n0 0 0 0\nnan 0 0 0\n0 1 0 0\n0 0 1 0\nTetrahedra\n1\n1 2 3 4 0\nEnd\n",
       "line 5: node 2: 'nan' is not a finite number"},
      {"dim.mesh", "Dimension 2\nVertices\n0\nEnd\n", "dimension 2 (goo needs 3)"},
      {"keyword.mesh", "Dimension 3\nBananas 3\nEnd\n", "unknown MEDIT keyword 'Bananas'"},
      {"truncated.mesh", "Dimension 3\nVertices\n4\n0 0 0 0\n1 0 0 0\n", "node 3: the file ends inside it"},
      {"empty.mesh", "", "the file is empty"},
      {"flat.mesh", "Dimension 3\nVertices\n4\n0 0 0 0\n1 0 0 0\n0 1 0 0\n1 1 0 0\nTetrahedra\n1\n1 2 3 4 0\nEnd\n",
       "tetrahedron 0 has zero volume"},
  };
  for (const auto& c : cases) {
    test::TempDir dir;
    const auto path = dir.write(c.name, c.contents);
    try {
      io::read_tet_mesh(path);
      ADD_FAILURE() << c.name << " was accepted";
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), HasSubstr(path.string() + ": ")) << c.name;
      EXPECT_THAT(e.what(), HasSubstr(c.expected)) << c.name;
    }
  }
  // TetGen: a missing .ele, an out-of-range id, a short file.
  test::TempDir dir;
  dir.write("t.node", nodes);
  EXPECT_TRUE(test::throws_error_containing([&] { io::read_tet_mesh(dir / "t.node"); }, "t.ele: cannot open"));
  dir.write("t.ele", "1 4 0\n1 1 2 3 5\n");
  try {
    io::read_tet_mesh(dir / "t.node");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(),
                HasSubstr("t.ele: line 2: tetrahedron 0 references node 5, but the mesh has 4 nodes (ids start at 1)"));
  }
  dir.write("t.ele", "2 4 0\n1 1 2 3 4\n");
  EXPECT_THROW(
      {
        try {
          io::read_tet_mesh(dir / "t.ele");
        } catch (const Error& e) {
          EXPECT_THAT(e.what(), HasSubstr("ends after 1 of the 2 tetrahedra"));
          throw;
        }
      },
      Error);
  EXPECT_TRUE(test::throws_error_containing([&] { io::read_tet_mesh(dir / "t.vtk"); },
                                            "unknown tetrahedral mesh format '.vtk'"));
}

}  // namespace
}  // namespace goo
