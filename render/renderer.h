#pragma once
// Offscreen OpenGL pictures of a run: shaded surfaces with per-body
// colours, translucent obstacles, a floor with shadows, optional lines (the
// tet mesh's edges). Headless: EGL on Mesa's surfaceless platform (llvmpipe
// on a machine without a GPU), so it needs no display (docs/rendering.md).
#include <array>
#include <memory>
#include <optional>
#include <vector>

#include "core/triangle_mesh.h"
#include "render/camera.h"
#include "render/image.h"

namespace goo::render {

using Colour = std::array<float, 3>;  ///< linear 0..1

struct MeshItem {
  const TriangleMesh* mesh = nullptr;
  Colour colour = {0.8f, 0.5f, 0.3f};
  float opacity = 1.0f;  ///< below 1: drawn see-through, after the opaque items
};

struct LineItem {
  std::vector<Eigen::Vector3d> segments;  ///< pairs of end points
  Colour colour = {0.1f, 0.1f, 0.1f};
};

struct Floor {
  double height = 0.0;         ///< m
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double half_size = 1.0;      ///< m: the floor drawn, fading out towards its edge
  double tile = 0.1;           ///< m: checker squares
};

struct Picture {
  std::vector<MeshItem> meshes;
  std::vector<LineItem> lines;
  std::optional<Floor> floor;
  /// What casts shadows and must be in the light's view (the run's bounds).
  Eigen::AlignedBox3d bounds;
};

/// A colour for body k, distinct for neighbouring k.
Colour body_colour(int k);

class Renderer {
 public:
  /// Creates the offscreen context; goo::Error (with what to install) when
  /// the machine has no EGL or OpenGL 3.3.
  Renderer(int width, int height);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  [[nodiscard]] Image draw(const Picture& picture, const Camera& camera);
  [[nodiscard]] int width() const;
  [[nodiscard]] int height() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace goo::render
