// Pictures: PNG files, the font, the camera's framing, and what the
// offscreen renderer draws (silhouettes against their projected corners,
// per-body colours, shadows, the same bits twice).
#include <gtest/gtest.h>

#include <fstream>
#include <random>

#include "core/error.h"
#include "core/primitives.h"
#include "render/camera.h"
#include "render/image.h"
#include "render/renderer.h"
#include "tests/common/test_common.h"

namespace goo::render {
namespace {

Eigen::Vector2d to_pixels(const Camera& camera, const Eigen::Vector3d& p, int width, int height) {
  const Eigen::Vector4d clip = camera.projection(static_cast<double>(width) / height) * camera.view() * p.homogeneous();
  const Eigen::Vector2d ndc = clip.head<2>() / clip.w();
  return {0.5 * (ndc.x() + 1.0) * width, 0.5 * (1.0 - ndc.y()) * height};
}

/// The area of the convex hull of points (gift wrapping; a few points).
double hull_area(std::vector<Eigen::Vector2d> p) {
  std::sort(p.begin(), p.end(), [](const auto& a, const auto& b) { return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y()); });
  auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
  };
  std::vector<Eigen::Vector2d> h(2 * p.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  for (std::size_t i = p.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross(h[k - 2], h[k - 1], p[i - 1]) <= 0) --k;
    h[k++] = p[i - 1];
  }
  h.resize(k - 1);
  double area = 0.0;
  for (std::size_t i = 0; i < h.size(); ++i) {
    const auto& a = h[i];
    const auto& b = h[(i + 1) % h.size()];
    area += a.x() * b.y() - a.y() * b.x();
  }
  return 0.5 * std::abs(area);
}

double hull_perimeter(const std::vector<Eigen::Vector2d>& corners) {
  // An upper bound is enough: the sum of the box's projected edge lengths.
  double sum = 0.0;
  for (std::size_t i = 0; i < corners.size(); ++i)
    for (std::size_t j = i + 1; j < corners.size(); ++j) sum = std::max(sum, (corners[i] - corners[j]).norm());
  return 4.0 * sum;  // a convex polygon's perimeter is at most π × its diameter
}

/// Pixels of `image` that differ from `empty` (the same view with nothing in it).
int differing(const Image& image, const Image& empty) {
  int n = 0;
  for (std::size_t i = 0; i < image.rgb.size(); i += 3)
    n += (image.rgb[i] != empty.rgb[i] || image.rgb[i + 1] != empty.rgb[i + 1] || image.rgb[i + 2] != empty.rgb[i + 2]);
  return n;
}

TEST(Png, RoundTripsEveryPixel) {
  Image image(37, 21);
  std::mt19937 random(3);
  for (auto& c : image.rgb) c = static_cast<std::uint8_t>(random() & 0xff);
  const Image back = decode_png(encode_png(image), "a.png");
  EXPECT_EQ(back.width, 37);
  EXPECT_EQ(back.height, 21);
  EXPECT_TRUE(back.rgb == image.rgb);
}

TEST(Png, RefusesWhatIsNotOne) {
  std::vector<std::uint8_t> bytes = encode_png(Image(40, 40));
  bytes.resize(bytes.size() / 2);
  EXPECT_THROW(decode_png(bytes, "half.png"), Error);
  const std::string text = "not a png";
  EXPECT_TRUE(test::throws_error_containing([&] { (void)decode_png({text.begin(), text.end()}, "b.png"); }, "b.png: not a readable PNG"));
}

TEST(Text, DrawsGlyphsInsideItsWidth) {
  Image image(200, 20);
  const std::uint8_t ink[3] = {0, 0, 0};
  const int width = draw_text(image, "frame 12  t = 0.5 s", 2, 2, 2, ink);
  EXPECT_EQ(width, text_width("frame 12  t = 0.5 s", 2));
  int inked = 0, outside = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      if (image.at(x, y)[0] == 0) (x >= 2 && x < 2 + width && y >= 2 && y < 2 + 14 ? inked : outside)++;
  EXPECT_GT(inked, 100);
  EXPECT_EQ(outside, 0);
}

TEST(Camera, FramesABoxInsideThePicture) {
  for (const double aspect : {0.5, 1.0, 4.0 / 3.0, 2.5})
    for (const double azimuth : {-30.0, 0.0, 120.0})
      for (const double elevation : {-40.0, 0.0, 25.0, 80.0}) {
        const Eigen::AlignedBox3d box(Eigen::Vector3d(-0.3, 1.0, 0.0), Eigen::Vector3d(0.5, 1.2, 0.9));
        const Camera c = frame_box(box, azimuth, elevation, aspect);
        const int height = 600, width = static_cast<int>(600 * aspect);
        for (int k = 0; k < 8; ++k) {
          const Eigen::Vector3d corner = box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(k));
          const Eigen::Vector2d p = to_pixels(c, corner, width, height);
          EXPECT_GT(p.x(), 0.0);
          EXPECT_LT(p.x(), width);
          EXPECT_GT(p.y(), 0.0);
          EXPECT_LT(p.y(), height);
          // Between the near and far planes.
          const double depth = -(c.view() * corner.homogeneous()).z();
          EXPECT_GT(depth, c.near);
          EXPECT_LT(depth, c.far);
        }
        // The box's centre is the picture's.
        const Eigen::Vector2d centre = to_pixels(c, box.center(), width, height);
        EXPECT_NEAR(centre.x(), 0.5 * width, 1e-6 * width);
        EXPECT_NEAR(centre.y(), 0.5 * height, 1e-6 * height);
      }
}

TEST(Renderer, ABoxCoversItsProjectedCorners) {
  // A box seen in perspective covers the convex hull of its corners'
  // projections: the pixels counted differ from that area only along the
  // outline, where multisampling blends (at most a pixel either side).
  const int width = 320, height = 240;
  Renderer renderer(width, height);
  const Eigen::Vector3d size(0.3, 0.2, 0.1);
  const TriangleMesh box = make_box(size, 2);
  const Eigen::AlignedBox3d bounds(-0.5 * size, 0.5 * size);
  for (const double azimuth : {-30.0, 45.0}) {
    const Camera camera = frame_box(bounds, azimuth, 30.0, static_cast<double>(width) / height);
    Picture picture;
    picture.meshes.push_back({&box, body_colour(0), 1.0f});
    picture.bounds = bounds;
    const Image image = renderer.draw(picture, camera);
    Picture nothing;
    nothing.bounds = bounds;
    const Image empty = renderer.draw(nothing, camera);
    std::vector<Eigen::Vector2d> corners;
    for (int k = 0; k < 8; ++k)
      corners.push_back(to_pixels(camera, bounds.corner(static_cast<Eigen::AlignedBox3d::CornerType>(k)), width, height));
    const double covered = differing(image, empty);
    const double area = hull_area(corners);
    EXPECT_NEAR(covered, area, hull_perimeter(corners)) << "azimuth " << azimuth;
    EXPECT_GT(area, 0.05 * width * height);  // the framing makes it large
  }
}

TEST(Renderer, SameBitsTwiceAndEachBodyInItsColour) {
  const int width = 200, height = 150;
  Renderer renderer(width, height);
  TriangleMesh left = make_box({0.1, 0.1, 0.1}, 1), right = left;
  left.vertices.col(0).array() -= 0.1;
  right.vertices.col(0).array() += 0.1;
  const Eigen::AlignedBox3d bounds(Eigen::Vector3d(-0.15, -0.05, -0.05), Eigen::Vector3d(0.15, 0.05, 0.05));
  const Camera camera = frame_box(bounds, 0.0, 10.0, static_cast<double>(width) / height);
  Picture picture;
  picture.meshes.push_back({&left, body_colour(0), 1.0f});
  picture.meshes.push_back({&right, body_colour(1), 1.0f});
  picture.bounds = bounds;
  const Image a = renderer.draw(picture, camera), b = renderer.draw(picture, camera);
  EXPECT_TRUE(a.rgb == b.rgb);
  const Eigen::Vector2d l = to_pixels(camera, Eigen::Vector3d(-0.1, -0.05, 0.0), width, height);
  const Eigen::Vector2d r = to_pixels(camera, Eigen::Vector3d(0.1, -0.05, 0.0), width, height);
  const std::uint8_t* pl = a.at(static_cast<int>(l.x()), static_cast<int>(l.y()));
  const std::uint8_t* pr = a.at(static_cast<int>(r.x()), static_cast<int>(r.y()));
  EXPECT_GT(pl[0], pl[2] + 40);  // body 0 is warm
  EXPECT_GT(pr[2], pr[0] + 40);  // body 1 is cool
}

TEST(Renderer, ABodyCastsAShadowOnTheFloor) {
  const int width = 240, height = 180;
  Renderer renderer(width, height);
  const TriangleMesh box = [] {
    TriangleMesh m = make_box({0.1, 0.1, 0.1}, 1);
    m.vertices.col(2).array() += 0.1;
    return m;
  }();
  const Eigen::AlignedBox3d bounds(Eigen::Vector3d(-0.05, -0.05, 0.0), Eigen::Vector3d(0.05, 0.05, 0.15));
  const Camera camera = frame_box(bounds, -30.0, 40.0, static_cast<double>(width) / height);
  Picture with, without;
  Floor floor;
  floor.half_size = 0.5;
  floor.tile = 1.0;  // one tile: an even floor
  with.floor = without.floor = floor;
  with.bounds = without.bounds = bounds;
  with.meshes.push_back({&box, body_colour(0), 1.0f});
  // A see-through copy is drawn but casts no shadow.
  without.meshes.push_back({&box, body_colour(0), 0.3f});
  const Image a = renderer.draw(with, camera), b = renderer.draw(without, camera);
  // Pixels the opaque box does not cover, darker with it: its shadow.
  int darker = 0;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const std::uint8_t *p = a.at(x, y), *q = b.at(x, y);
      const bool floor_only = p[2] >= p[0] && q[2] >= q[0];  // not the orange box in either picture
      if (floor_only && p[1] + 25 < q[1]) ++darker;
    }
  EXPECT_GT(darker, 200);
}

TEST(Renderer, RefusesImpossibleSizes) {
  EXPECT_THROW(Renderer(8, 100), Error);
  EXPECT_THROW(Renderer(100, 100000), Error);
}

}  // namespace
}  // namespace goo::render
