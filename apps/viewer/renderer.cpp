#include "apps/viewer/renderer.hpp"

#define GL_GLEXT_PROTOTYPES 1
#include <GL/gl.h>
#include <GL/glext.h>

#include "engine/simulation_internals.hpp"
#include "systems/carving/carving.hpp"
#include "systems/tearing/fiber_field.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

namespace pt::viewer {

// --- camera ----------------------------------------------------------------------------------------------

namespace {
constexpr double kPi = 3.14159265358979323846;
}

Vec3 Camera::eye() const {
  const Vec3 e2 = up.cross(e1);
  const Vec3 dir = std::cos(pitch) * (std::cos(yaw) * e1 + std::sin(yaw) * e2) + std::sin(pitch) * up;
  return target + distance * dir;
}

Mat4 Camera::view() const {
  const Vec3 f = forward();
  Vec3 s = f.cross(up);
  if (s.norm() < 1e-9) s = f.cross(e1);
  s.normalize();
  const Vec3 u = s.cross(f);
  Mat4 m = Mat4::Identity();
  m.block<1, 3>(0, 0) = s.transpose();
  m.block<1, 3>(1, 0) = u.transpose();
  m.block<1, 3>(2, 0) = -f.transpose();
  const Vec3 e = eye();
  m(0, 3) = -s.dot(e);
  m(1, 3) = -u.dot(e);
  m(2, 3) = f.dot(e);
  return m;
}

Mat4 Camera::projection() const {
  const double aspect = static_cast<double>(std::max(1, width)) / std::max(1, height);
  const double zn = std::max(1e-4, distance * 0.01), zf = distance * 100.0;
  const double t = 1.0 / std::tan(fov_deg * kPi / 360.0);
  Mat4 p = Mat4::Zero();
  p(0, 0) = t / aspect;
  p(1, 1) = t;
  p(2, 2) = (zf + zn) / (zn - zf);
  p(2, 3) = 2 * zf * zn / (zn - zf);
  p(3, 2) = -1;
  return p;
}

void Camera::ray(double px, double py, Vec3& origin, Vec3& dir) const {
  const double nx = 2.0 * (px + 0.5) / std::max(1, width) - 1.0;
  const double ny = 1.0 - 2.0 * (py + 0.5) / std::max(1, height);
  const Mat4 inv = (projection() * view()).inverse();
  Eigen::Vector4d a = inv * Eigen::Vector4d(nx, ny, -1, 1), b = inv * Eigen::Vector4d(nx, ny, 1, 1);
  origin = a.head<3>() / a.w();
  dir = (b.head<3>() / b.w() - origin).normalized();
}

bool Camera::project(const Vec3& p, double& px, double& py) const {
  const Eigen::Vector4d c = projection() * view() * Eigen::Vector4d(p.x(), p.y(), p.z(), 1.0);
  if (c.w() <= 0) return false;
  px = (c.x() / c.w() * 0.5 + 0.5) * width;
  py = (0.5 - c.y() / c.w() * 0.5) * height;
  return true;
}

void Camera::orbit(double dx, double dy) {
  yaw -= dx * 0.008;
  pitch = std::clamp(pitch + dy * 0.008, -1.55, 1.55);
}

void Camera::pan(double dx, double dy) {
  const Vec3 f = forward();
  Vec3 s = f.cross(up);
  if (s.norm() < 1e-9) s = f.cross(e1);
  s.normalize();
  const Vec3 u = s.cross(f);
  const double scale = 2.0 * distance * std::tan(fov_deg * kPi / 360.0) / std::max(1, height);
  target += (-dx * s + dy * u) * scale;
}

void Camera::zoom(double factor) { distance = std::clamp(distance * factor, 1e-3, 100.0); }

void Camera::frame_sheet(const Sheet& sheet, const Vec3& gravity) {
  up = gravity.norm() > 0 ? Vec3(-gravity.normalized()) : Vec3(0, 0, 1);
  // yaw 0 looks at the sheet's front (+z side) when up is in the sheet's plane, from the −y side
  // (a reader's view of a sheet on a table) when up is +z.
  Vec3 z(0, 0, 1);
  Vec3 cand = z - z.dot(up) * up;
  e1 = cand.norm() > 1e-6 ? Vec3(cand.normalized()) : Vec3(0, -1, 0);
  if (e1.cross(up).norm() < 1e-6) e1 = Vec3(1, 0, 0);
  pitch = cand.norm() > 1e-6 ? 0.25 : 0.95;
  yaw = 0;
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  for (const Vec3& x : sheet.verts.x) {
    if (!x.allFinite()) continue;
    lo = lo.cwiseMin(x);
    hi = hi.cwiseMax(x);
  }
  if (lo.x() > hi.x()) lo = hi = Vec3::Zero();
  target = 0.5 * (lo + hi);
  const double radius = std::max(0.02, 0.5 * (hi - lo).norm());
  distance = 1.25 * radius / std::tan(fov_deg * kPi / 360.0);
}

// --- GL helpers ----------------------------------------------------------------------------------------

namespace {

GLuint compile(GLenum type, const char* src) {
  GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &src, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    std::fprintf(stderr, "papertear-viewer: shader: %s\n", log);
    glDeleteShader(s);
    return 0;
  }
  return s;
}

GLuint link(const std::string& vs, const std::string& fs) {
  GLuint v = compile(GL_VERTEX_SHADER, vs.c_str()), f = compile(GL_FRAGMENT_SHADER, fs.c_str());
  if (!v || !f) return 0;
  GLuint p = glCreateProgram();
  glAttachShader(p, v);
  glAttachShader(p, f);
  glLinkProgram(p);
  glDeleteShader(v);
  glDeleteShader(f);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetProgramInfoLog(p, sizeof log, nullptr, log);
    std::fprintf(stderr, "papertear-viewer: program: %s\n", log);
    return 0;
  }
  return p;
}

const char* kSheetVS = R"(#version 330 core
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec2 a_uv;
layout(location = 3) in float a_side;
uniform mat4 u_mvp;
out vec3 v_pos;
out vec3 v_normal;
out vec2 v_uv;
flat out int v_side;
void main() {
  v_pos = a_pos;
  v_normal = a_normal;
  v_uv = a_uv;
  v_side = int(a_side + 0.5);
  gl_Position = u_mvp * vec4(a_pos, 1.0);
}
)";

// Compiled twice: with CARVED for the triangles whose texture footprint meets a carved label tile, and
// without for the others, where every label is 0 (untouched paper) and the lookup would change nothing.
// On llvmpipe the label fetch (a gather from a texture of several MB) is the most expensive part of a
// fragment, and most of the sheet is far from any tear.
const char* kSheetFS = R"(
in vec3 v_pos;
in vec3 v_normal;
in vec2 v_uv;
flat in int v_side;
uniform sampler2D u_paper;
uniform usampler2D u_labels;
uniform vec2 u_origin;      // texture frame origin (pattern m)
uniform float u_pixel;      // m per label pixel
uniform ivec2 u_label_size;
uniform vec2 u_paper_extent;  // pattern m covered by the paper texture
uniform vec3 u_eye;
uniform vec3 u_light;       // unit, towards the key light
out vec4 frag;
void main() {
  bool path = false;
#ifdef CARVED
  ivec2 px = ivec2(floor((v_uv - u_origin) / u_pixel));
  if (px.x >= 0 && px.y >= 0 && px.x < u_label_size.x && px.y < u_label_size.y) {
    uint l = texelFetch(u_labels, px, 0).r;
    if (l == 65535u) path = true;
    else if (v_side > 0 && l != 0u && (int(l) - 1) / 2 == (v_side - 1) / 2 && int(l) != v_side) discard;
  }
#endif
  vec3 n = normalize(v_normal);
  if (!gl_FrontFacing) n = -n;
  vec3 view = normalize(u_eye - v_pos);
  if (dot(n, view) < 0.0) n = -n;   // smooth normals near folds: light the side we see
  float fiber = texture(u_paper, (v_uv - u_origin) / u_paper_extent).r;
  vec3 front = vec3(0.97, 0.95, 0.89), back = vec3(0.86, 0.89, 0.95);
  // The fibres' formation at ±3% of the brightness, as office paper shows it (±9% read as parchment).
  vec3 base = (gl_FrontFacing ? front : back) * (0.94 + 0.06 * fiber);
  if (path) base *= vec3(0.80, 0.74, 0.66);  // broken fibres along the detailed tear
  float key = max(dot(n, u_light), 0.0);
  float head = max(dot(n, view), 0.0);
  vec3 h = normalize(u_light + view);
  float spec = max(dot(n, h), 0.0);  // ^32 by squaring: llvmpipe's pow is exp2(log2) polynomials
  spec *= spec;
  spec *= spec;
  spec *= spec;
  spec *= spec;
  spec *= spec;
  spec *= 0.06;
  vec3 c = base * (0.28 + 0.47 * key + 0.30 * head) + vec3(spec);
  frag = vec4(c, 1.0);
}
)";

const char* kLineVS = R"(#version 330 core
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_color;
uniform mat4 u_mvp;
uniform float u_point_size;
uniform float u_lift;
out vec3 v_color;
void main() {
  v_color = a_color;
  gl_Position = u_mvp * vec4(a_pos, 1.0);
  gl_Position.z -= u_lift * gl_Position.w;  // in front of the surface it lies on
  gl_PointSize = u_point_size;
}
)";

const char* kLineFS = R"(#version 330 core
in vec3 v_color;
out vec4 frag;
void main() { frag = vec4(v_color, 1.0); }
)";

void to_float(const Mat4& m, float out[16]) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) out[c * 4 + r] = static_cast<float>(m(r, c));
}

}  // namespace

// --- layer ---------------------------------------------------------------------------------------------

namespace {

const char* kLayerVS = R"(#version 330 core
uniform vec4 u_rect;  // the rectangle in layer texture coordinates: x0, y0, x1, y1
out vec2 v_uv;
void main() {
  vec2 corner = vec2(gl_VertexID & 1, gl_VertexID >> 1);  // triangle strip of the viewport
  v_uv = mix(u_rect.xy, u_rect.zw, corner);
  gl_Position = vec4(corner * 2.0 - 1.0, 0.0, 1.0);
}
)";

const char* kLayerFS = R"(#version 330 core
uniform sampler2D u_layer;
in vec2 v_uv;
out vec4 frag;
void main() { frag = texture(u_layer, v_uv); }
)";

}  // namespace

Layer::~Layer() {
  if (program_) glDeleteProgram(program_);
  if (vao_) glDeleteVertexArrays(1, &vao_);
  if (fbo_) glDeleteFramebuffers(1, &fbo_);
  if (tex_) glDeleteTextures(1, &tex_);
}

void Layer::begin(int w, int h, const std::array<float, 4>& clear) {
  w = std::max(1, w);
  h = std::max(1, h);
  if (!fbo_) {
    glGenFramebuffers(1, &fbo_);
    glGenTextures(1, &tex_);
  }
  if (w != w_ || h != h_) {
    w_ = w;
    h_ = h;
    glBindTexture(GL_TEXTURE_2D, tex_);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, w_, h_, 0, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glBindTexture(GL_TEXTURE_2D, 0);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, tex_, 0);
  }
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glViewport(0, 0, w_, h_);
  glDisable(GL_SCISSOR_TEST);
  glClearColor(clear[0], clear[1], clear[2], clear[3]);
  glClear(GL_COLOR_BUFFER_BIT);
}

void Layer::end() { glBindFramebuffer(GL_FRAMEBUFFER, 0); }

void Layer::copy_to_window(int x, int y, int w, int h, int dst_x, int dst_y) const {
  if (!fbo_ || w <= 0 || h <= 0) return;
  glDisable(GL_SCISSOR_TEST);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
  glBlitFramebuffer(x, y, x + w, y + h, dst_x, dst_y, dst_x + w, dst_y + h, GL_COLOR_BUFFER_BIT, GL_NEAREST);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

void Layer::composite(int x, int y, int w, int h) const {
  x = std::max(0, x);
  y = std::max(0, y);
  w = std::min(w, w_ - x);
  h = std::min(h, h_ - y);
  if (!fbo_ || w <= 0 || h <= 0) return;
  if (!program_) {
    program_ = link(kLayerVS, kLayerFS);
    glGenVertexArrays(1, &vao_);
    if (!program_) return;
  }
  glViewport(x, y, w, h);
  glDisable(GL_SCISSOR_TEST);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glEnable(GL_BLEND);
  glBlendEquation(GL_FUNC_ADD);
  glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
  glUseProgram(program_);
  glUniform4f(glGetUniformLocation(program_, "u_rect"), float(x) / w_, float(y) / h_, float(x + w) / w_,
              float(y + h) / h_);
  glUniform1i(glGetUniformLocation(program_, "u_layer"), 0);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, tex_);
  glBindVertexArray(vao_);
  glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
  glBindVertexArray(0);
  glBindTexture(GL_TEXTURE_2D, 0);
  glUseProgram(0);
  glDisable(GL_BLEND);
}

// --- renderer ------------------------------------------------------------------------------------------

Renderer::~Renderer() {
  if (sheet_program_) glDeleteProgram(sheet_program_);
  if (carved_program_) glDeleteProgram(carved_program_);
  if (line_program_) glDeleteProgram(line_program_);
  GLuint vaos[4] = {sheet_vao_, line_vao_, pattern_vao_, obstacle_vao_},
         vbos[4] = {sheet_vbo_, line_vbo_, pattern_vbo_, obstacle_vbo_}, texs[2] = {paper_tex_, label_tex_};
  glDeleteVertexArrays(4, vaos);
  glDeleteBuffers(4, vbos);
  glDeleteTextures(2, texs);
}

bool Renderer::init() {
  const std::string version = "#version 330 core\n";
  sheet_program_ = link(kSheetVS, version + kSheetFS);
  carved_program_ = link(kSheetVS, version + "#define CARVED 1\n" + kSheetFS);
  line_program_ = link(kLineVS, kLineFS);
  if (!sheet_program_ || !carved_program_ || !line_program_) return false;
  glGenVertexArrays(1, &sheet_vao_);
  glGenBuffers(1, &sheet_vbo_);
  glBindVertexArray(sheet_vao_);
  glBindBuffer(GL_ARRAY_BUFFER, sheet_vbo_);
  const GLsizei stride = 9 * sizeof(float);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(0));
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(3 * sizeof(float)));
  glVertexAttribPointer(2, 2, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(6 * sizeof(float)));
  glVertexAttribPointer(3, 1, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(8 * sizeof(float)));
  for (int i = 0; i < 4; ++i) glEnableVertexAttribArray(i);
  // Lines and the pattern inset share one vertex layout: position and colour, three floats each.
  auto position_colour_vao = [](unsigned& vao, unsigned& vbo) {
    glGenVertexArrays(1, &vao);
    glGenBuffers(1, &vbo);
    glBindVertexArray(vao);
    glBindBuffer(GL_ARRAY_BUFFER, vbo);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), reinterpret_cast<void*>(0));
    glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), reinterpret_cast<void*>(3 * sizeof(float)));
    glEnableVertexAttribArray(0);
    glEnableVertexAttribArray(1);
  };
  position_colour_vao(line_vao_, line_vbo_);
  position_colour_vao(pattern_vao_, pattern_vbo_);
  position_colour_vao(obstacle_vao_, obstacle_vbo_);
  glBindVertexArray(0);
  glGenTextures(1, &paper_tex_);
  glGenTextures(1, &label_tex_);
  return true;
}

namespace {
// The scenario's obstacles as coloured triangles (position, colour): a plane as a checkered square around
// the sheet's foot on it, `extent` a side, a box as its six faces shaded by their direction.
std::vector<float> obstacle_triangles(const std::vector<Obstacle>& obstacles, const Vec3& centre, double extent) {
  std::vector<float> out;
  auto put = [&](const Vec3& p, const Vec3& c) {
    for (int k = 0; k < 3; ++k) out.push_back(float(p[k]));
    for (int k = 0; k < 3; ++k) out.push_back(float(c[k]));
  };
  auto quad = [&](const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, const Vec3& col) {
    put(a, col), put(b, col), put(c, col);
    put(a, col), put(c, col), put(d, col);
  };
  for (const Obstacle& o : obstacles) {
    if (o.kind == Obstacle::Kind::Plane) {
      const Vec3 n = (o.normal / o.normal.cwiseAbs().maxCoeff()).normalized();
      int least = 0;
      for (int k = 1; k < 3; ++k)
        if (std::abs(n[k]) < std::abs(n[least])) least = k;
      const Vec3 u = n.cross(Vec3::Unit(least)).normalized(), w = n.cross(u);
      const Vec3 foot = centre - n.dot(centre - o.point) * n;
      constexpr int kTiles = 12;
      const double tile = extent / kTiles;
      for (int i = 0; i < kTiles; ++i)
        for (int j = 0; j < kTiles; ++j) {
          const Vec3 a = foot + (i - kTiles / 2) * tile * u + (j - kTiles / 2) * tile * w;
          const Vec3 col = (i + j) % 2 ? Vec3(0.42, 0.40, 0.36) : Vec3(0.50, 0.47, 0.42);
          quad(a, a + tile * u, a + tile * u + tile * w, a + tile * w, col);
        }
      continue;
    }
    const Vec3 lo = o.min, hi = o.max;
    for (int axis = 0; axis < 3; ++axis)
      for (const int side : {0, 1}) {
        const int b = (axis + 1) % 3, c = (axis + 2) % 3;
        auto corner = [&](bool tb, bool tc) {
          Vec3 p;
          p[axis] = side ? hi[axis] : lo[axis];
          p[b] = tb ? hi[b] : lo[b];
          p[c] = tc ? hi[c] : lo[c];
          return p;
        };
        const double shade = axis == 2 ? (side ? 0.75 : 0.35) : (axis == 0 ? 0.55 : 0.62) + (side ? 0.05 : -0.05);
        const Vec3 col = shade * Vec3(0.55, 0.62, 0.75);
        quad(corner(false, false), corner(true, false), corner(true, true), corner(false, true), col);
      }
  }
  return out;
}
}  // namespace

void Renderer::load_sheet(const Simulation& sim) {
  {
    const Sheet& sheet = sim.sheet();
    Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
    for (const Vec3& x : sheet.verts.x) lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
    if (lo.x() > hi.x()) lo = hi = Vec3::Zero();
    const std::vector<float> data =
        obstacle_triangles(sim.scenario().obstacles, 0.5 * (lo + hi), std::max(0.3, 3 * (hi - lo).norm()));
    glBindVertexArray(obstacle_vao_);
    glBindBuffer(GL_ARRAY_BUFFER, obstacle_vbo_);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(data.size() * sizeof(float)), data.data(), GL_STATIC_DRAW);
    glBindVertexArray(0);
    obstacle_vertices_ = static_cast<int32_t>(data.size() / 6);
  }
  const DetailParams& d = detail_params(sim);
  tex_origin_ = d.origin;
  tex_pixel_ = d.pixel_size;
  label_w_ = std::max(1, d.width);
  label_h_ = std::max(1, d.height);
  paper_extent_ = Vec2(label_w_ * tex_pixel_, label_h_ * tex_pixel_);

  // Paper: the fibre field sampled over the texture frame (at most 512 texels a side; the field's
  // structure is ~mm, so this shows its grain at viewing distance).
  const int pw = std::min(512, label_w_), ph = std::max(1, static_cast<int>(std::lround(pw * double(label_h_) / label_w_)));
  std::vector<unsigned char> paper(static_cast<size_t>(pw) * ph);
  std::vector<double> values(paper.size());
  double lo = 1e300, hi = -1e300;
  for (int j = 0; j < ph; ++j)
    for (int i = 0; i < pw; ++i) {
      const Vec2 uv = tex_origin_ + Vec2((i + 0.5) / pw * paper_extent_.x(), (j + 0.5) / ph * paper_extent_.y());
      const double v = fiber_sample(fiber_field(sim), uv);
      values[static_cast<size_t>(j) * pw + i] = v;
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  for (size_t k = 0; k < values.size(); ++k)
    paper[k] = static_cast<unsigned char>(std::clamp((values[k] - lo) / std::max(1e-12, hi - lo), 0.0, 1.0) * 255.0);
  glBindTexture(GL_TEXTURE_2D, paper_tex_);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_R8, pw, ph, 0, GL_RED, GL_UNSIGNED_BYTE, paper.data());
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);

  // Side labels: a full-size integer texture, zero (untouched paper); carved tiles are uploaded as they
  // appear.
  std::vector<uint16_t> zero(static_cast<size_t>(label_w_) * label_h_, 0);
  glBindTexture(GL_TEXTURE_2D, label_tex_);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 2);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_R16UI, label_w_, label_h_, 0, GL_RED_INTEGER, GL_UNSIGNED_SHORT, zero.data());
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glBindTexture(GL_TEXTURE_2D, 0);
  labels_carved_ = -1;
  tiles_uploaded_ = 0;
  tile_shadow_.clear();
  carved_tiles_.clear();
}

void Renderer::upload_labels(const Simulation& sim) {
  const CarveState& cs = carve_state(sim);
  if (cs.carved_segments == labels_carved_) return;
  labels_carved_ = cs.carved_segments;
  glBindTexture(GL_TEXTURE_2D, label_tex_);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 2);
  glPixelStorei(GL_UNPACK_ROW_LENGTH, kTileSize);
  if (tile_shadow_.size() < cs.tiles.size()) tile_shadow_.resize(cs.tiles.size());
  for (size_t k = 0; k < cs.tile_keys.size(); ++k) {
    const LabelTile& tile_k = *cs.tiles[cs.tile_slot[k]];
    std::vector<uint16_t>& shadow = tile_shadow_[cs.tile_slot[k]];
    if (shadow.size() == tile_k.label.size() &&
        std::equal(shadow.begin(), shadow.end(), tile_k.label.begin()))
      continue;  // unchanged since the last upload
    shadow.assign(tile_k.label.begin(), tile_k.label.end());
    const int tx = static_cast<int>(cs.tile_keys[k] & 0xFFFFu), ty = static_cast<int>(cs.tile_keys[k] >> 16);
    const int x0 = tx * kTileSize, y0 = ty * kTileSize;
    if (x0 >= label_w_ || y0 >= label_h_) continue;
    const int w = std::min(kTileSize, label_w_ - x0), h = std::min(kTileSize, label_h_ - y0);
    const LabelTile& tile = *cs.tiles[cs.tile_slot[k]];
    glTexSubImage2D(GL_TEXTURE_2D, 0, x0, y0, w, h, GL_RED_INTEGER, GL_UNSIGNED_SHORT, tile.label.data());
    ++tiles_uploaded_;
  }
  glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  glBindTexture(GL_TEXTURE_2D, 0);

  tiles_x_ = (label_w_ + kTileSize - 1) / kTileSize;
  tiles_y_ = (label_h_ + kTileSize - 1) / kTileSize;
  carved_tiles_.assign(static_cast<size_t>(tiles_x_) * tiles_y_, 0);
  for (const uint32_t key : cs.tile_keys) {
    const int tx = static_cast<int>(key & 0xFFFFu), ty = static_cast<int>(key >> 16);
    if (tx < tiles_x_ && ty < tiles_y_) carved_tiles_[static_cast<size_t>(ty) * tiles_x_ + tx] = 1;
  }
}

bool Renderer::touches_carved_tile(const Vec2& a, const Vec2& b, const Vec2& c) const {
  if (carved_tiles_.empty()) return false;
  const Vec2 lo = a.cwiseMin(b).cwiseMin(c), hi = a.cwiseMax(b).cwiseMax(c);
  // The label pixels the fragment shader can fetch for this triangle (its texture coordinates are
  // convex combinations of the corners'), one pixel wider against rounding.
  auto pixel = [&](double u, double origin, int size) {
    const double p = std::floor((u - origin) / tex_pixel_);
    return static_cast<int>(std::clamp(p, -1.0, static_cast<double>(size)));
  };
  const int i0 = std::max(0, pixel(lo.x(), tex_origin_.x(), label_w_) - 1);
  const int i1 = std::min(label_w_ - 1, pixel(hi.x(), tex_origin_.x(), label_w_) + 1);
  const int j0 = std::max(0, pixel(lo.y(), tex_origin_.y(), label_h_) - 1);
  const int j1 = std::min(label_h_ - 1, pixel(hi.y(), tex_origin_.y(), label_h_) + 1);
  if (i0 > i1 || j0 > j1) return false;
  for (int ty = j0 / kTileSize; ty <= j1 / kTileSize; ++ty)
    for (int tx = i0 / kTileSize; tx <= i1 / kTileSize; ++tx)
      if (carved_tiles_[static_cast<size_t>(ty) * tiles_x_ + tx]) return true;
  return false;
}

void Renderer::prepare(const Simulation& sim, bool wireframe) {
  const Sheet& s = sim.sheet();
  const int32_t nv = s.verts.size(), nt = s.tris.size();
  upload_labels(sim);

  // Smooth normals (area weighted), oriented like the pattern's counter-clockwise side.
  normals_.assign(nv, Vec3::Zero());
  for (int32_t t = 0; t < nt; ++t) {
    const Tri& c = s.tris.tri[t];
    const Vec3 n = (s.verts.x[c[1]] - s.verts.x[c[0]]).cross(s.verts.x[c[2]] - s.verts.x[c[0]]);
    if (!n.allFinite()) continue;
    for (int k = 0; k < 3; ++k) normals_[c[k]] += n;
  }
  for (Vec3& n : normals_) n = n.norm() > 0 ? Vec3(n.normalized()) : Vec3(0, 0, 1);
  assign_triangle_sides(s.verts.rest, s.verts.tear, s.tris.tri, s.tears, sides_);

  // Triangles that can show a carved label first (drawn with the carving shader), then the others.
  order_.clear();
  for (int32_t t = 0; t < nt; ++t) {
    const Tri& c = s.tris.tri[t];
    if (touches_carved_tile(s.verts.rest[c[0]], s.verts.rest[c[1]], s.verts.rest[c[2]])) order_.push_back(t);
  }
  const int32_t n_carved = static_cast<int32_t>(order_.size());
  for (int32_t t = 0, next = 0; t < nt; ++t) {
    if (next < n_carved && order_[next] == t) ++next;
    else order_.push_back(t);
  }

  sheet_data_.resize(static_cast<size_t>(nt) * 27);
  float* out = sheet_data_.data();
  for (const int32_t t : order_) {
    const Tri& c = s.tris.tri[t];
    for (int k = 0; k < 3; ++k) {
      const Vec3& x = s.verts.x[c[k]];
      const Vec3& n = normals_[c[k]];
      const Vec2& r = s.verts.rest[c[k]];
      *out++ = float(x.x()), *out++ = float(x.y()), *out++ = float(x.z());
      *out++ = float(n.x()), *out++ = float(n.y()), *out++ = float(n.z());
      *out++ = float(r.x()), *out++ = float(r.y());
      *out++ = float(t < static_cast<int32_t>(sides_.size()) ? sides_[t] : 0);
    }
  }

  // Lines: the sheet's boundary (outline grey, tear lips dark brown), and the wireframe if asked.
  line_data_.clear();
  auto line = [&](const Vec3& a, const Vec3& b, const Vec3& col) {
    for (const Vec3* p : {&a, &b}) {
      line_data_.push_back(float(p->x()));
      line_data_.push_back(float(p->y()));
      line_data_.push_back(float(p->z()));
      line_data_.push_back(float(col.x()));
      line_data_.push_back(float(col.y()));
      line_data_.push_back(float(col.z()));
    }
  };
  const Vec3 outline_col(0.35, 0.35, 0.38), tear_col(0.45, 0.18, 0.05), wire_col(0.55, 0.6, 0.7);
  if (static_cast<int32_t>(s.topo.boundary_next.size()) == nv) {
    for (int32_t v = 0; v < nv; ++v) {
      const int32_t w = s.topo.boundary_next[v];
      if (w < 0) continue;
      const bool lip = s.verts.tear[v] >= 0 && s.verts.tear[w] >= 0;
      line(s.verts.x[v], s.verts.x[w], lip ? tear_col : outline_col);
    }
  }
  if (wireframe)
    for (int32_t t = 0; t < nt; ++t) {
      const Tri& c = s.tris.tri[t];
      for (int k = 0; k < 3; ++k)
        if (c[k] < c[(k + 1) % 3]) line(s.verts.x[c[k]], s.verts.x[c[(k + 1) % 3]], wire_col);
    }

  glBindVertexArray(sheet_vao_);
  glBindBuffer(GL_ARRAY_BUFFER, sheet_vbo_);
  if (sheet_data_ != sheet_uploaded_) {  // paused or still: nothing to send
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(sheet_data_.size() * sizeof(float)), sheet_data_.data(),
                 GL_STREAM_DRAW);
    sheet_uploaded_.swap(sheet_data_);
  }
  if (!line_data_.empty()) {
    glBindVertexArray(line_vao_);
    glBindBuffer(GL_ARRAY_BUFFER, line_vbo_);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(line_data_.size() * sizeof(float)), line_data_.data(),
                 GL_STREAM_DRAW);
  }
  glBindVertexArray(0);
  prepared_triangles_ = nt;
  prepared_carved_ = n_carved;
  prepared_line_vertices_ = static_cast<int32_t>(line_data_.size() / 6);
}

void Renderer::draw_prepared(const Camera& camera) {
  const int32_t nt = prepared_triangles_, n_carved = prepared_carved_;
  float mvp[16];
  to_float(camera.projection() * camera.view(), mvp);
  const Vec3 eye = camera.eye();
  const Vec3 light = (camera.up * 0.8 + (eye - camera.target).normalized() * 0.6 +
                      camera.up.cross(camera.forward()).normalized() * 0.3).normalized();

  glEnable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);  // both sides
  glEnable(GL_POLYGON_OFFSET_FILL);
  if (obstacle_vertices_ > 0) {
    // Behind the sheet that rests on them (half a thickness above): pushed back further than the sheet.
    glPolygonOffset(4.0f, 16.0f);
    glUseProgram(line_program_);
    glUniformMatrix4fv(glGetUniformLocation(line_program_, "u_mvp"), 1, GL_FALSE, mvp);
    glUniform1f(glGetUniformLocation(line_program_, "u_lift"), 0.0f);
    glUniform1f(glGetUniformLocation(line_program_, "u_point_size"), 1.0f);
    glBindVertexArray(obstacle_vao_);
    glDrawArrays(GL_TRIANGLES, 0, obstacle_vertices_);
  }
  glPolygonOffset(1.0f, 1.0f);
  auto use_sheet_program = [&](GLuint program) {
    glUseProgram(program);
    glUniformMatrix4fv(glGetUniformLocation(program, "u_mvp"), 1, GL_FALSE, mvp);
    glUniform2f(glGetUniformLocation(program, "u_origin"), float(tex_origin_.x()), float(tex_origin_.y()));
    glUniform1f(glGetUniformLocation(program, "u_pixel"), float(tex_pixel_));
    glUniform2i(glGetUniformLocation(program, "u_label_size"), label_w_, label_h_);
    glUniform2f(glGetUniformLocation(program, "u_paper_extent"), float(paper_extent_.x()), float(paper_extent_.y()));
    glUniform3f(glGetUniformLocation(program, "u_eye"), float(eye.x()), float(eye.y()), float(eye.z()));
    glUniform3f(glGetUniformLocation(program, "u_light"), float(light.x()), float(light.y()), float(light.z()));
    glUniform1i(glGetUniformLocation(program, "u_paper"), 0);
    glUniform1i(glGetUniformLocation(program, "u_labels"), 1);
  };
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, paper_tex_);
  glActiveTexture(GL_TEXTURE1);
  glBindTexture(GL_TEXTURE_2D, label_tex_);
  glBindVertexArray(sheet_vao_);
  if (n_carved > 0) {
    use_sheet_program(carved_program_);
    glDrawArrays(GL_TRIANGLES, 0, n_carved * 3);
  }
  if (n_carved < nt) {
    use_sheet_program(sheet_program_);
    glDrawArrays(GL_TRIANGLES, n_carved * 3, (nt - n_carved) * 3);
  }
  glDisable(GL_POLYGON_OFFSET_FILL);

  if (prepared_line_vertices_ > 0) {
    glUseProgram(line_program_);
    glUniformMatrix4fv(glGetUniformLocation(line_program_, "u_mvp"), 1, GL_FALSE, mvp);
    glUniform1f(glGetUniformLocation(line_program_, "u_lift"), 2e-4f);
    glUniform1f(glGetUniformLocation(line_program_, "u_point_size"), 1.0f);
    glBindVertexArray(line_vao_);
    glDrawArrays(GL_LINES, 0, prepared_line_vertices_);
  }
  glBindVertexArray(0);
  glActiveTexture(GL_TEXTURE1);
  glBindTexture(GL_TEXTURE_2D, 0);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, 0);
  glUseProgram(0);
}

void Renderer::show_pattern(int x, int y, int w, int h) const {
  if (w < 8 || h < 8) return;
  pattern_layer_.copy_to_window(0, 0, w, h, x, y);
}

void Renderer::prepare_pattern(const Simulation& sim, int w, int h, const std::vector<int>& selected) {
  if (w < 8 || h < 8) return;
  const Sheet& s = sim.sheet();
  const Scenario& sc = sim.scenario();
  Vec2 lo = Vec2::Constant(1e300), hi = Vec2::Constant(-1e300);
  for (const Vec2& p : sc.outline) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  // Orthographic map of the outline's box (5% margin) into the rectangle, aspect kept.
  const Vec2 c = 0.5 * (lo + hi);
  const double half = 0.55 * std::max((hi.x() - lo.x()) / w, (hi.y() - lo.y()) / h);  // m per pixel / 2 · 1.1
  Mat4 m = Mat4::Identity();
  m(0, 0) = 1.0 / (half * w);
  m(1, 1) = 1.0 / (half * h);
  m(0, 3) = -c.x() * m(0, 0);
  m(1, 3) = -c.y() * m(1, 1);
  m(2, 2) = 0;
  float mvp[16];
  to_float(m, mvp);

  fill_data_.clear();
  line_data_.clear();
  auto put = [](std::vector<float>& out, const Vec2& p, const Vec3& col) {
    out.insert(out.end(), {float(p.x()), float(p.y()), 0.f, float(col.x()), float(col.y()), float(col.z())});
  };
  const Vec3 kind_col[3] = {Vec3(0.88, 0.87, 0.82), Vec3(0.59, 0.75, 0.92), Vec3(0.94, 0.71, 0.47)};
  for (int32_t t = 0; t < s.tris.size(); ++t) {
    const Tri& tr = s.tris.tri[t];
    const int32_t r = t < static_cast<int32_t>(s.tris.region.size()) ? s.tris.region[t] : -1;
    const int kind = (r >= 0 && r < static_cast<int32_t>(s.regions.size())) ? static_cast<int>(s.regions[r].kind) : 0;
    for (int k = 0; k < 3; ++k) put(fill_data_, s.verts.rest[tr[k]], kind_col[std::clamp(kind, 0, 2)]);
  }
  const size_t fill_count = fill_data_.size() / 6;
  const Vec3 wire(0.45, 0.45, 0.5), tear_col(0.05, 0.05, 0.05);
  for (int32_t t = 0; t < s.tris.size(); ++t) {
    const Tri& tr = s.tris.tri[t];
    for (int k = 0; k < 3; ++k)
      if (tr[k] < tr[(k + 1) % 3]) {
        put(line_data_, s.verts.rest[tr[k]], wire);
        put(line_data_, s.verts.rest[tr[(k + 1) % 3]], wire);
      }
  }
  const size_t wire_count = line_data_.size() / 6;
  for (const Tear& tear : s.tears) {
    const auto& path = tear.detail.size() >= 2 ? tear.detail : tear.tips;
    for (size_t k = 1; k < path.size(); ++k) {
      put(line_data_, path[k - 1], tear_col);
      put(line_data_, path[k], tear_col);
    }
  }
  // A pad's disc (systems/physics/fingers.hpp) as a ring in its finger's colour.
  for (int i = 0; i < static_cast<int>(s.fingers.size()); ++i) {
    const Finger& f = s.fingers[i];
    if (f.vertex < 0 || !(f.pad_radius > 0)) continue;
    const bool sel = std::find(selected.begin(), selected.end(), i) != selected.end();
    const Vec3 col = sel ? Vec3(1.0, 0.8, 0.1) : Vec3(0.9, 0.08, 0.08);
    constexpr int kSegments = 32;
    for (int k = 0; k < kSegments; ++k)
      for (const int e : {k, k + 1}) {
        const double a = 2 * std::numbers::pi * e / kSegments;
        put(line_data_, f.uv + f.pad_radius * Vec2(std::cos(a), std::sin(a)), col);
      }
  }
  const size_t line_count = line_data_.size() / 6;
  // Points: candidates, tear tips, fingers (drawn last, largest).
  for (const Candidate& cd : tearing_candidates(sim))
    if (cd.vertex >= 0 && cd.vertex < s.verts.size()) put(line_data_, s.verts.rest[cd.vertex], Vec3(0.95, 0.62, 0.0));
  const size_t cand_end = line_data_.size() / 6;
  for (const Tear& tear : s.tears)
    for (const Vec2& p : tear.tips) put(line_data_, p, Vec3(0.55, 0.15, 0.65));
  const size_t tips_end = line_data_.size() / 6;
  for (int i = 0; i < static_cast<int>(s.fingers.size()); ++i) {
    const Finger& f = s.fingers[i];
    if (f.vertex < 0) continue;
    const bool sel = std::find(selected.begin(), selected.end(), i) != selected.end();
    put(line_data_, f.uv, sel ? Vec3(1.0, 0.8, 0.1) : Vec3(0.9, 0.08, 0.08));
  }
  const size_t fingers_end = line_data_.size() / 6;

  // Everything the inset shows: the vertices (fills, then lines and points), their ranges, the map.
  fill_data_.insert(fill_data_.end(), line_data_.begin(), line_data_.end());
  fill_data_.insert(fill_data_.end(), mvp, mvp + 16);
  fill_data_.push_back(float(w));
  fill_data_.push_back(float(h));
  const std::array<size_t, 6> counts = {fill_count, wire_count, line_count, cand_end, tips_end, fingers_end};
  glDisable(GL_DEPTH_TEST);
  if (fill_data_ != pattern_drawn_ || counts != pattern_counts_ || pattern_layer_.width() != w ||
      pattern_layer_.height() != h) {
    ++pattern_redraws_;
    pattern_counts_ = counts;
    pattern_layer_.begin(w, h);
    glClearColor(0.13f, 0.13f, 0.16f, 1.0f);
    glClear(GL_COLOR_BUFFER_BIT);
    glEnable(GL_PROGRAM_POINT_SIZE);
    glUseProgram(line_program_);
    glUniformMatrix4fv(glGetUniformLocation(line_program_, "u_mvp"), 1, GL_FALSE, mvp);
    glUniform1f(glGetUniformLocation(line_program_, "u_lift"), 0.f);
    const GLint ps = glGetUniformLocation(line_program_, "u_point_size");
    glUniform1f(ps, 1.f);
    glBindVertexArray(pattern_vao_);
    glBindBuffer(GL_ARRAY_BUFFER, pattern_vbo_);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>((fill_count + fingers_end) * 6 * sizeof(float)),
                 fill_data_.data(), GL_STREAM_DRAW);
    const GLint first_line = static_cast<GLint>(fill_count);  // lines and points follow the fills
    glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(fill_count));
    glDrawArrays(GL_LINES, first_line, static_cast<GLsizei>(wire_count));
    glLineWidth(2.0f);  // where supported; 1 px otherwise
    glDrawArrays(GL_LINES, first_line + static_cast<GLint>(wire_count), static_cast<GLsizei>(line_count - wire_count));
    glLineWidth(1.0f);
    glUniform1f(ps, 5.f);
    glDrawArrays(GL_POINTS, first_line + static_cast<GLint>(line_count), static_cast<GLsizei>(cand_end - line_count));
    glUniform1f(ps, 4.f);
    glDrawArrays(GL_POINTS, first_line + static_cast<GLint>(cand_end), static_cast<GLsizei>(tips_end - cand_end));
    glUniform1f(ps, 10.f);
    glDrawArrays(GL_POINTS, first_line + static_cast<GLint>(tips_end), static_cast<GLsizei>(fingers_end - tips_end));
    glBindVertexArray(0);
    glUseProgram(0);
    glDisable(GL_PROGRAM_POINT_SIZE);
    pattern_layer_.end();
    pattern_drawn_.swap(fill_data_);
  }
}

}  // namespace pt::viewer
