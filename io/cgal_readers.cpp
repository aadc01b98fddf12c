// The one translation unit of goo::io that includes CGAL (its headers are
// slow to compile; conventions.md).
#include <CGAL/IO/OFF.h>
#include <CGAL/IO/PLY.h>
#include <CGAL/IO/STL.h>
#include <CGAL/Simple_cartesian.h>

#include "io/detail/polygon_soup_readers.h"

namespace goo::io::detail {

bool read_with_cgal(const std::filesystem::path& path, MeshFormat format, PolygonSoup& soup) {
  using Point = CGAL::Simple_cartesian<double>::Point_3;
  std::vector<Point> points;
  const auto quiet = CGAL::parameters::verbose(false);
  bool ok = false;
  switch (format) {
    case MeshFormat::off:
      ok = CGAL::IO::read_OFF(path.string(), points, soup.polygons, quiet);
      break;
    case MeshFormat::ply:
      ok = CGAL::IO::read_PLY(path.string(), points, soup.polygons, quiet);
      break;
    case MeshFormat::stl: {
      std::vector<std::array<std::size_t, 3>> triangles;
      ok = CGAL::IO::read_STL(path.string(), points, triangles, quiet);
      soup.polygons.reserve(triangles.size());
      for (const auto& t : triangles) soup.polygons.push_back({t[0], t[1], t[2]});
      break;
    }
    case MeshFormat::obj:
      return false;  // tinyobjloader reads OBJ
  }
  soup.points.reserve(points.size());
  for (const Point& p : points) soup.points.push_back({p.x(), p.y(), p.z()});
  return ok;
}

}  // namespace goo::io::detail
