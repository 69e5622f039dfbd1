// OpenGL 3.3 core drawing of one sheet for papertear-viewer: the deformed mesh with a paper texture (the
// sheet's fibre field) and the carved tear details (pixels beyond a tear's detailed path on the other
// lip are cut away by alpha test against the carving side-label map), both sides lit; boundary and tear
// edges as lines; an orbit camera.
#pragma once

#include "engine/simulation.hpp"

#include <Eigen/Geometry>

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
  // Draw the current state.
  void draw(const Simulation& sim, const Camera& camera, bool wireframe);
  // The 2D pattern inset in the framebuffer rectangle (x, y from the bottom left, w × h pixels): the
  // mesh with regions coloured by kind (flat: paper, curved +: blue, curved −: orange), candidates
  // (amber), tears (detailed path black, coarse tips violet), fingers (red; selected ones yellow).
  void draw_pattern(const Simulation& sim, int x, int y, int w, int h, const std::vector<int>& selected);

  int32_t label_tiles_uploaded() const { return tiles_uploaded_; }

 private:
  void upload_labels(const Simulation& sim);

  unsigned sheet_program_ = 0, line_program_ = 0;
  unsigned sheet_vao_ = 0, sheet_vbo_ = 0, line_vao_ = 0, line_vbo_ = 0;
  unsigned paper_tex_ = 0, label_tex_ = 0;
  int label_w_ = 0, label_h_ = 0;
  Vec2 tex_origin_ = Vec2::Zero();
  double tex_pixel_ = 1e-4;
  Vec2 paper_extent_ = Vec2(1, 1);
  int64_t labels_carved_ = -1;  // CarveState::carved_segments at the last label upload
  int32_t tiles_uploaded_ = 0;
  std::vector<float> sheet_data_, line_data_, fill_data_;
  std::vector<std::vector<uint16_t>> tile_shadow_;  // per CarveState tile slot: content last uploaded
  std::vector<Vec3> normals_;
  std::vector<int32_t> sides_;
};

}  // namespace pt::viewer
