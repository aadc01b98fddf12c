#include "render/renderer.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#define GL_GLEXT_PROTOTYPES
#include <GL/glcorearb.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "core/error.h"

namespace goo::render {
namespace {

constexpr int kSamples = 4;        // multisampling: smooth edges
constexpr int kShadowSize = 2048;  // shadow map texels per side

// The light comes from high up on the right of the default view (azimuth
// −30°): shadows fall to the left and back, where the camera sees them.
const Eigen::Vector3d kLight = Eigen::Vector3d(0.45, -0.2, 1.0).normalized();

constexpr const char* kMeshVertex = R"(#version 330 core
layout(location = 0) in vec3 position;
uniform mat4 mvp;
uniform mat4 light_mvp;
out vec3 world;
out vec4 light_position;
void main() {
  world = position;
  light_position = light_mvp * vec4(position, 1.0);
  gl_Position = mvp * vec4(position, 1.0);
}
)";

// Flat shading from the screen derivatives of the position: every facet
// shows, as it is (a crumpled surface looks crumpled). Two-sided.
constexpr const char* kMeshFragment = R"(#version 330 core
in vec3 world;
in vec4 light_position;
uniform vec3 colour;
uniform float opacity;
uniform vec3 eye;
uniform vec3 light;
uniform sampler2DShadow shadow_map;
uniform int is_floor;
uniform vec4 floor_shape;  // centre x, centre y, half size, tile
uniform vec2 world_offset; // positions are relative to it: the tiles stay put when the camera moves
out vec4 fragment;
float lit(vec3 n) {
  vec3 q = light_position.xyz / light_position.w * 0.5 + 0.5;
  if (any(lessThan(q, vec3(0.0))) || any(greaterThan(q, vec3(1.0)))) return 1.0;
  vec2 texel = 1.0 / vec2(textureSize(shadow_map, 0));
  float bias = 0.0015 + 0.002 * (1.0 - abs(dot(n, light)));
  float sum = 0.0;
  for (int i = -2; i <= 2; ++i)
    for (int j = -2; j <= 2; ++j) sum += texture(shadow_map, vec3(q.xy + vec2(i, j) * texel, q.z - bias));
  return sum / 25.0;
}
void main() {
  vec3 n;
  vec3 base = colour;
  float alpha = opacity;
  if (is_floor == 1) {
    n = vec3(0.0, 0.0, 1.0);
    vec2 cell = floor((world.xy + world_offset) / floor_shape.w);
    base = mod(cell.x + cell.y, 2.0) < 0.5 ? vec3(0.55) : vec3(0.70);
    float r = length(world.xy - floor_shape.xy) / floor_shape.z;
    alpha = 1.0 - smoothstep(0.55, 1.0, r);
  } else {
    n = normalize(cross(dFdx(world), dFdy(world)));
  }
  vec3 v = normalize(eye - world);
  if (dot(n, v) < 0.0) n = -n;
  float shadow = lit(n);
  vec3 fill = normalize(vec3(0.6, 0.2, 0.3));
  vec3 sky = mix(vec3(0.16, 0.15, 0.14), vec3(0.30, 0.33, 0.38), 0.5 + 0.5 * n.z);
  float diffuse = max(dot(n, light), 0.0) * shadow;
  float specular = is_floor == 1 ? 0.0 : pow(max(dot(n, normalize(light + v)), 0.0), 40.0) * 0.3 * shadow;
  vec3 c = base * (sky + 0.8 * diffuse + 0.15 * max(dot(n, fill), 0.0)) + vec3(specular);
  fragment = vec4(pow(clamp(c, 0.0, 1.0), vec3(1.0 / 2.2)), alpha);
}
)";

constexpr const char* kDepthFragment = R"(#version 330 core
void main() {}
)";

constexpr const char* kLineVertex = R"(#version 330 core
layout(location = 0) in vec3 position;
uniform mat4 mvp;
void main() { gl_Position = mvp * vec4(position, 1.0); }
)";
constexpr const char* kLineFragment = R"(#version 330 core
uniform vec3 colour;
out vec4 fragment;
void main() { fragment = vec4(pow(colour, vec3(1.0 / 2.2)), 1.0); }
)";

// A vertical gradient behind everything.
constexpr const char* kBackgroundVertex = R"(#version 330 core
out float height;
void main() {
  vec2 p = vec2((gl_VertexID == 1) ? 3.0 : -1.0, (gl_VertexID == 2) ? 3.0 : -1.0);
  height = 0.5 * p.y + 0.5;
  gl_Position = vec4(p, 1.0, 1.0);
}
)";
constexpr const char* kBackgroundFragment = R"(#version 330 core
in float height;
out vec4 fragment;
void main() { fragment = vec4(mix(vec3(0.80, 0.82, 0.85), vec3(0.96, 0.97, 0.98), clamp(height, 0.0, 1.0)), 1.0); }
)";

GLuint compile(GLenum kind, const char* source) {
  const GLuint shader = glCreateShader(kind);
  glShaderSource(shader, 1, &source, nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048] = {};
    glGetShaderInfoLog(shader, sizeof log, nullptr, log);
    throw Error(fmt::format("the renderer's shader does not compile: {}", log));
  }
  return shader;
}

GLuint program(const char* vertex, const char* fragment) {
  const GLuint p = glCreateProgram();
  const GLuint v = compile(GL_VERTEX_SHADER, vertex), f = compile(GL_FRAGMENT_SHADER, fragment);
  glAttachShader(p, v);
  glAttachShader(p, f);
  glLinkProgram(p);
  glDeleteShader(v);
  glDeleteShader(f);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[2048] = {};
    glGetProgramInfoLog(p, sizeof log, nullptr, log);
    throw Error(fmt::format("the renderer's shaders do not link: {}", log));
  }
  return p;
}

Eigen::Matrix4f to_float(const Eigen::Matrix4d& m) { return m.cast<float>(); }

/// An orthographic light camera looking along −kLight that holds `box`.
Eigen::Matrix4d light_matrix(const Eigen::AlignedBox3d& box) {
  Camera c;
  const double radius = std::max(0.5 * box.diagonal().norm(), 1e-6);
  c.target = box.center();
  c.eye = c.target + 2.0 * radius * kLight;
  c.up = std::abs(kLight.z()) > 0.9 ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitZ();
  Eigen::Matrix4d ortho = Eigen::Matrix4d::Identity();
  ortho(0, 0) = ortho(1, 1) = 1.0 / radius;
  ortho(2, 2) = -1.0 / (2.0 * radius);  // depth 0 .. 4 radius → −1 .. 1
  ortho(2, 3) = -1.0;
  return ortho * c.view();
}

}  // namespace

Colour body_colour(int k) {
  // Warm and cool colours alternating, as a clay and a jelly.
  static constexpr Colour kPalette[] = {{0.85f, 0.38f, 0.16f}, {0.18f, 0.45f, 0.80f}, {0.30f, 0.65f, 0.25f},
                                        {0.75f, 0.25f, 0.55f}, {0.85f, 0.68f, 0.15f}, {0.20f, 0.65f, 0.65f}};
  const int n = static_cast<int>(std::size(kPalette));
  return kPalette[static_cast<std::size_t>(((k % n) + n) % n)];
}

struct Renderer::Impl {
  int width = 0, height = 0;
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  GLuint msaa_fbo = 0, msaa_colour = 0, msaa_depth = 0;
  GLuint resolve_fbo = 0, resolve_colour = 0;
  GLuint shadow_fbo = 0, shadow_texture = 0;
  GLuint mesh_program = 0, depth_program = 0, line_program = 0, background_program = 0;
  GLuint vao = 0, vertex_buffer = 0, index_buffer = 0;

  void open();
  void close();
  /// Uploads positions (relative to `origin`, as floats) and indices.
  GLsizei upload(const TriangleMesh& mesh, const Eigen::Vector3d& origin);
  GLsizei upload_lines(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& origin);
  void uniform(GLuint p, const char* name, const Eigen::Matrix4f& m) {
    glUniformMatrix4fv(glGetUniformLocation(p, name), 1, GL_FALSE, m.data());
  }
  void uniform(GLuint p, const char* name, const Eigen::Vector3f& v) {
    glUniform3f(glGetUniformLocation(p, name), v.x(), v.y(), v.z());
  }
};

void Renderer::Impl::open() {
  auto get_platform_display =
      reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (get_platform_display)
    display = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  EGLint major = 0, minor = 0;
  if (display == EGL_NO_DISPLAY || !eglInitialize(display, &major, &minor))
    throw Error(
        "cannot render: no offscreen EGL display (install Debian's libegl-mesa0 and libgl1-mesa-dri, or run "
        "scripts/setup-deps)");
  const EGLint config_attributes[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT,
                                      EGL_NONE};
  EGLConfig config = nullptr;
  EGLint configs = 0;
  eglChooseConfig(display, config_attributes, &config, 1, &configs);
  if (!eglBindAPI(EGL_OPENGL_API)) throw Error("cannot render: EGL has no desktop OpenGL");
  const EGLint context_attributes[] = {EGL_CONTEXT_MAJOR_VERSION,        3, EGL_CONTEXT_MINOR_VERSION, 3,
                                       EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                       EGL_NONE};
  context = eglCreateContext(display, configs > 0 ? config : EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, context_attributes);
  if (context == EGL_NO_CONTEXT || !eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context))
    throw Error(fmt::format("cannot render: no OpenGL 3.3 context (EGL error {:#x}; install libgl1-mesa-dri)",
                            eglGetError()));

  GLint max_size = 0;
  glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_size);
  if (width > max_size || height > max_size)
    throw Error(fmt::format("cannot render {}×{} pictures: this OpenGL allows at most {} pixels a side", width,
                            height, max_size));
  glGenFramebuffers(1, &msaa_fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, msaa_fbo);
  glGenRenderbuffers(1, &msaa_colour);
  glBindRenderbuffer(GL_RENDERBUFFER, msaa_colour);
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, kSamples, GL_RGBA8, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, msaa_colour);
  glGenRenderbuffers(1, &msaa_depth);
  glBindRenderbuffer(GL_RENDERBUFFER, msaa_depth);
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, kSamples, GL_DEPTH_COMPONENT24, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, msaa_depth);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw Error("cannot render: the offscreen framebuffer is incomplete");

  glGenFramebuffers(1, &resolve_fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, resolve_fbo);
  glGenRenderbuffers(1, &resolve_colour);
  glBindRenderbuffer(GL_RENDERBUFFER, resolve_colour);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, resolve_colour);

  glGenTextures(1, &shadow_texture);
  glBindTexture(GL_TEXTURE_2D, shadow_texture);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT24, kShadowSize, kShadowSize, 0, GL_DEPTH_COMPONENT, GL_FLOAT,
               nullptr);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
  glGenFramebuffers(1, &shadow_fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, shadow_fbo);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, shadow_texture, 0);
  glDrawBuffer(GL_NONE);
  glReadBuffer(GL_NONE);

  mesh_program = program(kMeshVertex, kMeshFragment);
  depth_program = program(kMeshVertex, kDepthFragment);
  line_program = program(kLineVertex, kLineFragment);
  background_program = program(kBackgroundVertex, kBackgroundFragment);
  glGenVertexArrays(1, &vao);
  glBindVertexArray(vao);
  glGenBuffers(1, &vertex_buffer);
  glGenBuffers(1, &index_buffer);
  glBindBuffer(GL_ARRAY_BUFFER, vertex_buffer);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, index_buffer);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
}

void Renderer::Impl::close() {
  if (context != EGL_NO_CONTEXT) {
    glDeleteBuffers(1, &vertex_buffer);
    glDeleteBuffers(1, &index_buffer);
    glDeleteVertexArrays(1, &vao);
    for (GLuint p : {mesh_program, depth_program, line_program, background_program}) glDeleteProgram(p);
    for (GLuint f : {msaa_fbo, resolve_fbo, shadow_fbo}) glDeleteFramebuffers(1, &f);
    for (GLuint r : {msaa_colour, msaa_depth, resolve_colour}) glDeleteRenderbuffers(1, &r);
    glDeleteTextures(1, &shadow_texture);
    eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(display, context);
  }
  // The display is not terminated: EGL has one per platform and process, the
  // next renderer initialises the same one again, and Mesa's termination
  // leaves blocks of its shader compiler behind (LeakSanitizer reports them).
  eglReleaseThread();  // EGL's per-thread state: nothing of it outlives the renderer
}

GLsizei Renderer::Impl::upload(const TriangleMesh& mesh, const Eigen::Vector3d& origin) {
  std::vector<float> positions(3 * static_cast<std::size_t>(mesh.num_vertices()));
  for (Index v = 0; v < mesh.num_vertices(); ++v)
    for (int k = 0; k < 3; ++k)
      positions[3 * static_cast<std::size_t>(v) + static_cast<std::size_t>(k)] =
          static_cast<float>(mesh.vertices(v, k) - origin[k]);
  std::vector<GLuint> indices(3 * static_cast<std::size_t>(mesh.num_triangles()));
  for (Index t = 0; t < mesh.num_triangles(); ++t)
    for (int k = 0; k < 3; ++k)
      indices[3 * static_cast<std::size_t>(t) + static_cast<std::size_t>(k)] = static_cast<GLuint>(mesh.triangles(t, k));
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(positions.size() * sizeof(float)), positions.data(),
               GL_STREAM_DRAW);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(indices.size() * sizeof(GLuint)), indices.data(),
               GL_STREAM_DRAW);
  return static_cast<GLsizei>(indices.size());
}

GLsizei Renderer::Impl::upload_lines(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& origin) {
  std::vector<float> positions;
  positions.reserve(3 * points.size());
  for (const auto& p : points)
    for (int k = 0; k < 3; ++k) positions.push_back(static_cast<float>(p[k] - origin[k]));
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(positions.size() * sizeof(float)), positions.data(),
               GL_STREAM_DRAW);
  return static_cast<GLsizei>(points.size());
}

Renderer::Renderer(int width, int height) : impl_(std::make_unique<Impl>()) {
  if (width < 16 || height < 16 || width > 16384 || height > 16384)
    throw Error(fmt::format("cannot render {}×{} pictures: each side must be 16 to 16384 pixels", width, height));
  impl_->width = width;
  impl_->height = height;
  try {
    impl_->open();
  } catch (...) {
    impl_->close();
    throw;
  }
}

Renderer::~Renderer() { impl_->close(); }

int Renderer::width() const { return impl_->width; }
int Renderer::height() const { return impl_->height; }

Image Renderer::draw(const Picture& picture, const Camera& camera) {
  Impl& r = *impl_;
  // Coordinates relative to the target: floats keep the detail of a small
  // body far from the origin.
  const Eigen::Vector3d origin = camera.target;
  Eigen::Matrix4d shift = Eigen::Matrix4d::Identity();
  shift.block<3, 1>(0, 3) = origin;
  const double aspect = static_cast<double>(r.width) / static_cast<double>(r.height);
  const Eigen::Matrix4f mvp = to_float(camera.projection(aspect) * camera.view() * shift);
  Eigen::AlignedBox3d bounds = picture.bounds;
  if (bounds.isEmpty()) bounds = Eigen::AlignedBox3d(camera.target, camera.target);
  const Eigen::Matrix4f light_mvp = to_float(light_matrix(bounds) * shift);

  std::vector<const MeshItem*> opaque, translucent;
  for (const MeshItem& m : picture.meshes)
    if (m.mesh && m.mesh->num_triangles() > 0) (m.opacity < 1.0f ? translucent : opaque).push_back(&m);

  // 1. The shadow map: depth seen from the light, of everything solid.
  glBindFramebuffer(GL_FRAMEBUFFER, r.shadow_fbo);
  glViewport(0, 0, kShadowSize, kShadowSize);
  glEnable(GL_DEPTH_TEST);
  glDepthMask(GL_TRUE);
  glClear(GL_DEPTH_BUFFER_BIT);
  glEnable(GL_POLYGON_OFFSET_FILL);
  glPolygonOffset(1.5f, 2.0f);
  glUseProgram(r.depth_program);
  r.uniform(r.depth_program, "mvp", light_mvp);
  r.uniform(r.depth_program, "light_mvp", light_mvp);
  for (const MeshItem* m : opaque) glDrawElements(GL_TRIANGLES, r.upload(*m->mesh, origin), GL_UNSIGNED_INT, nullptr);
  glDisable(GL_POLYGON_OFFSET_FILL);

  // 2. The picture: background, floor, opaque surfaces, lines, see-through obstacles.
  glBindFramebuffer(GL_FRAMEBUFFER, r.msaa_fbo);
  glViewport(0, 0, r.width, r.height);
  glClearColor(1.0f, 1.0f, 1.0f, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glDisable(GL_DEPTH_TEST);
  glUseProgram(r.background_program);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glEnable(GL_DEPTH_TEST);
  glEnable(GL_BLEND);
  glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);

  glUseProgram(r.mesh_program);
  const GLuint p = r.mesh_program;
  r.uniform(p, "mvp", mvp);
  r.uniform(p, "light_mvp", light_mvp);
  r.uniform(p, "eye", Eigen::Vector3f((camera.eye - origin).cast<float>()));
  r.uniform(p, "light", Eigen::Vector3f(kLight.cast<float>()));
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, r.shadow_texture);
  glUniform1i(glGetUniformLocation(p, "shadow_map"), 0);
  if (picture.floor) {
    const Floor& f = *picture.floor;
    TriangleMesh quad;
    quad.vertices.resize(4, 3);
    const double x0 = f.centre.x() - f.half_size, x1 = f.centre.x() + f.half_size;
    const double y0 = f.centre.y() - f.half_size, y1 = f.centre.y() + f.half_size;
    quad.vertices << x0, y0, f.height, x1, y0, f.height, x1, y1, f.height, x0, y1, f.height;
    quad.triangles.resize(2, 3);
    quad.triangles << 0, 1, 2, 0, 2, 3;
    glUniform1i(glGetUniformLocation(p, "is_floor"), 1);
    glUniform4f(glGetUniformLocation(p, "floor_shape"), static_cast<float>(f.centre.x() - origin.x()),
                static_cast<float>(f.centre.y() - origin.y()), static_cast<float>(f.half_size),
                static_cast<float>(f.tile));
    glUniform2f(glGetUniformLocation(p, "world_offset"), static_cast<float>(origin.x()),
                static_cast<float>(origin.y()));
    glDepthMask(GL_FALSE);  // the floor never hides what lies on it
    glDrawElements(GL_TRIANGLES, r.upload(quad, origin), GL_UNSIGNED_INT, nullptr);
    glDepthMask(GL_TRUE);
  }
  glUniform1i(glGetUniformLocation(p, "is_floor"), 0);
  glEnable(GL_POLYGON_OFFSET_FILL);  // lines drawn on a surface stay visible
  glPolygonOffset(1.0f, 1.0f);
  for (const MeshItem* m : opaque) {
    r.uniform(p, "colour", Eigen::Vector3f(m->colour[0], m->colour[1], m->colour[2]));
    glUniform1f(glGetUniformLocation(p, "opacity"), 1.0f);
    glDrawElements(GL_TRIANGLES, r.upload(*m->mesh, origin), GL_UNSIGNED_INT, nullptr);
  }
  glDisable(GL_POLYGON_OFFSET_FILL);

  if (!picture.lines.empty()) {
    glUseProgram(r.line_program);
    r.uniform(r.line_program, "mvp", mvp);
    for (const LineItem& l : picture.lines) {
      if (l.segments.empty()) continue;
      r.uniform(r.line_program, "colour", Eigen::Vector3f(l.colour[0], l.colour[1], l.colour[2]));
      glDrawArrays(GL_LINES, 0, r.upload_lines(l.segments, origin));
    }
  }

  if (!translucent.empty()) {
    glUseProgram(p);
    glDepthMask(GL_FALSE);
    glEnable(GL_CULL_FACE);  // the near side of each obstacle only: no doubled tint
    glCullFace(GL_BACK);
    for (const MeshItem* m : translucent) {
      r.uniform(p, "colour", Eigen::Vector3f(m->colour[0], m->colour[1], m->colour[2]));
      glUniform1f(glGetUniformLocation(p, "opacity"), m->opacity);
      glDrawElements(GL_TRIANGLES, r.upload(*m->mesh, origin), GL_UNSIGNED_INT, nullptr);
    }
    glDisable(GL_CULL_FACE);
    glDepthMask(GL_TRUE);
  }
  glDisable(GL_BLEND);

  // 3. Resolve the samples and read the pixels back, top row first.
  glBindFramebuffer(GL_READ_FRAMEBUFFER, r.msaa_fbo);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, r.resolve_fbo);
  glBlitFramebuffer(0, 0, r.width, r.height, 0, 0, r.width, r.height, GL_COLOR_BUFFER_BIT, GL_NEAREST);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, r.resolve_fbo);
  std::vector<std::uint8_t> rgba(4 * static_cast<std::size_t>(r.width) * static_cast<std::size_t>(r.height));
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, r.width, r.height, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
  const GLenum error = glGetError();
  if (error != GL_NO_ERROR) throw Error(fmt::format("rendering failed (OpenGL error {:#x})", error));
  Image image(r.width, r.height);
  for (int y = 0; y < r.height; ++y)
    for (int x = 0; x < r.width; ++x) {
      const std::uint8_t* s =
          rgba.data() + 4 * (static_cast<std::size_t>(r.height - 1 - y) * static_cast<std::size_t>(r.width) +
                             static_cast<std::size_t>(x));
      std::copy_n(s, 3, image.at(x, y));
    }
  return image;
}

}  // namespace goo::render
