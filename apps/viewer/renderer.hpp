// OpenGL 3.3 core drawing of one sheet for papertear-viewer: the deformed mesh with a paper texture (the
// sheet's fibre field) and the carved tear details (pixels beyond a tear's detailed path on the other
// lip are cut away by alpha test against the carving side-label map), both sides lit; boundary and tear
// edges as lines; the scenario's obstacles (a checkered floor, shaded boxes); an orbit camera.
#pragma once

#include "engine/simulation.hpp"

#include <Eigen/Geometry>

#include <array>
#include <cstdint>
#include <vector>

namespace pt::viewer {

using Mat4 = Eigen::Matrix4d;

struct Camera {
  Vec3 target = Vec3::Zero();
  Vec3 up = Vec3(0, 0, 1);       // world "up" (against gravity)
  Vec3 e1 = Vec3(0, -1, 0);      // horizontal basis, yaw 0 looks along −e1
  double yaw = 0, pitch = 0.9, distance = 0.5, fov_deg = 40;
  int width = 1, height = 1;     // viewport, pixels

  Vec3 eye() const;
  Vec3 forward() const { return (target - eye()).normalized(); }
  Mat4 view() const;
  Mat4 projection() const;
  // World ray through window pixel (px, py), y down.
  void ray(double px, double py, Vec3& origin, Vec3& dir) const;
  // Window pixel of a world point; false behind the camera.
  bool project(const Vec3& p, double& px, double& py) const;
  // Orbit, pan (pixels), zoom (factor).
  void orbit(double dx, double dy);
  void pan(double dx, double dy);
  void zoom(double factor);
  // Frames the sheet's bounding box, up = −gravity.
  void frame_sheet(const Sheet& sheet, const Vec3& gravity);
};

// An offscreen colour layer (RGBA8 texture + framebuffer) for content that changes less often than
// frames are drawn: it is drawn again only when its content changed and copied to the window every frame.
// On llvmpipe a copy (or a blended quad) costs a fraction of drawing the content again.
class Layer {
 public:
  Layer() = default;
  ~Layer();
  Layer(const Layer&) = delete;
  Layer& operator=(const Layer&) = delete;

  // Binds the layer's framebuffer for drawing, w × h pixels, cleared to `clear` (default transparent
  // black); the viewport covers it. (Re)allocates on a size change.
  void begin(int w, int h, const std::array<float, 4>& clear = {0, 0, 0, 0});
  // Binds the window's framebuffer again.
  void end();
  // Copies the rectangle (x, y, w, h) of the layer (bottom-left origin) to the window at (dst_x, dst_y):
  // opaque content, an exact copy of the pixels.
  void copy_to_window(int x, int y, int w, int h, int dst_x, int dst_y) const;
  // Composites the rectangle (x, y, w, h) over the same rectangle of the bound framebuffer (the window's
  // or another layer's of the same size), the layer holding
  // premultiplied colour (what drawing with glBlendFuncSeparate(SRC_ALPHA, ONE_MINUS_SRC_ALPHA, ONE,
  // ONE_MINUS_SRC_ALPHA) over transparent black leaves): the result equals drawing onto the window (to
  // 1/255: the layer stores 8 bits).
  void composite(int x, int y, int w, int h) const;
  int width() const { return w_; }
  int height() const { return h_; }

 private:
  unsigned fbo_ = 0, tex_ = 0;
  mutable unsigned program_ = 0, vao_ = 0;
  int w_ = 0, h_ = 0;
};

class Renderer {
 public:
  Renderer() = default;
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // GL objects (needs a current GL 3.3 context). Returns false with a message on stderr on failure.
  bool init();
  // New sheet (after reset): paper texture from the fibre field, empty label texture.
  void load_sheet(const Simulation& sim);
  // Drawing the current state in two parts. prepare does everything that reads the simulation: vertex
  // data built and uploaded, carved labels uploaded. After it the simulation may step (on another thread)
  // while draw_prepared draws what was uploaded.
  void prepare(const Simulation& sim, bool wireframe);
  void draw_prepared(const Camera& camera);
  // The 2D pattern inset, w × h pixels: the mesh with regions coloured by kind (flat: paper, curved +:
  // blue, curved −: orange), candidates (amber), tears (detailed path black, coarse tips violet), fingers
  // (red; selected ones yellow). prepare_pattern reads the simulation and draws into a layer only when
  // any of that changed (remeshing, tearing, fingers, selection, size); show_pattern copies the layer to
  // the framebuffer rectangle at (x, y) from the bottom left.
  void prepare_pattern(const Simulation& sim, int w, int h, const std::vector<int>& selected);
  void show_pattern(int x, int y, int w, int h) const;

  int32_t label_tiles_uploaded() const { return tiles_uploaded_; }
  // How many times the pattern inset was drawn (not copied from its layer).
  int64_t pattern_redraws() const { return pattern_redraws_; }

 private:
  void upload_labels(const Simulation& sim);
  // Whether a triangle with these pattern corners can fetch a label from a carved tile.
  bool touches_carved_tile(const Vec2& a, const Vec2& b, const Vec2& c) const;

  unsigned sheet_program_ = 0, carved_program_ = 0, line_program_ = 0;
  unsigned sheet_vao_ = 0, sheet_vbo_ = 0, line_vao_ = 0, line_vbo_ = 0;
  unsigned paper_tex_ = 0, label_tex_ = 0;
  int label_w_ = 0, label_h_ = 0;
  Vec2 tex_origin_ = Vec2::Zero();
  double tex_pixel_ = 1e-4;
  Vec2 paper_extent_ = Vec2(1, 1);
  int64_t labels_carved_ = -1;  // CarveState::carved_segments at the last label upload
  int32_t tiles_uploaded_ = 0;
  std::vector<uint8_t> carved_tiles_;  // tiles_y_ × tiles_x_: 1 where CarveState has a tile
  int tiles_x_ = 0, tiles_y_ = 0;
  std::vector<int32_t> order_;          // triangles in drawing order: carved ones first
  std::vector<float> sheet_data_, sheet_uploaded_, line_data_, fill_data_;
  int32_t prepared_triangles_ = 0, prepared_carved_ = 0, prepared_line_vertices_ = 0;  // what prepare uploaded
  // Pattern inset: its own buffer and layer, and what was drawn into it last.
  unsigned pattern_vao_ = 0, pattern_vbo_ = 0;
  unsigned obstacle_vao_ = 0, obstacle_vbo_ = 0;  // the scenario's planes and boxes, built at load_sheet
  int32_t obstacle_vertices_ = 0;
  Layer pattern_layer_;
  std::vector<float> pattern_drawn_;
  std::array<size_t, 6> pattern_counts_{};
  int64_t pattern_redraws_ = 0;
  std::vector<std::vector<uint16_t>> tile_shadow_;  // per CarveState tile slot: content last uploaded
  std::vector<Vec3> normals_;
  std::vector<int32_t> sides_;
};

}  // namespace pt::viewer
