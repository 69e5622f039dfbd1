// PNG output of the paper texture and its carving (paper §6.2, §7.4; DESIGN §5.6): the 2D pattern with
// the detailed tears at texture resolution (`--png`, Fig. 19), the per-side RGBA textures whose pixels
// beyond the detailed path are transparent (`--obj`), and a plain RGBA writer others reuse.
#pragma once

#include "components/sheet.hpp"
#include "systems/carving.hpp"
#include "systems/fiber_field.hpp"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace pt {

// A window of the texture in pixels (x right, y up, as the pattern). width or height 0: the whole texture.
struct PixelRect {
  int32_t x = 0, y = 0;
  int32_t width = 0, height = 0;
};

struct PatternStyle {
  std::array<uint8_t, 3> paper{246, 242, 232};
  std::array<uint8_t, 3> background{72, 72, 78};   // outside the outline
  std::array<uint8_t, 3> path{139, 0, 0};          // detailed tear path: dark red
  std::array<uint8_t, 3> left_tint{60, 110, 230};  // side labels, blended lightly
  std::array<uint8_t, 3> right_tint{235, 140, 30};
  double tint = 0.14;    // blend weight of the side tints
  double fiber = 0.22;   // paper brightness varies by ±fiber/2 with T_fiber
};

// Write a width × height RGBA8 image (row 0 is the top row) to `path`. Throws std::runtime_error.
void write_rgba_png(const std::string& path, int32_t width, int32_t height, const std::vector<uint8_t>& rgba);
void write_rgba_png(const std::string& path, int32_t width, int32_t height, const uint8_t* rgba);

// The 2D pattern at texture resolution into `rgba` (rect.width × rect.height, row 0 = top = largest
// pattern y): paper colour modulated by T_fiber inside the outline, side labels tinted, detailed paths
// dark red (from the label map and from each tear's `detail`). Returns the rect actually rendered.
PixelRect render_pattern_rgba(const std::vector<Vec2>& outline, const std::vector<Tear>& tears,
                              const CarveState& state, const DetailParams& params, const FiberField& fiber,
                              const PixelRect& rect, const PatternStyle& style, std::vector<uint8_t>& rgba);

// render_pattern_rgba + write_rgba_png (`--png`).
void write_pattern_png(const std::string& path, const std::vector<Vec2>& outline, const std::vector<Tear>& tears,
                       const CarveState& state, const DetailParams& params, const FiberField& fiber,
                       const PixelRect& rect = {}, const PatternStyle& style = {});

// The paper texture as seen by triangles with side label `side` (0: untouched triangles): alpha 0 where
// pixel_visible is false (beyond the detailed path of that side's tear) and outside the outline, so a
// textured OBJ shows the carved edge in any viewer that honours alpha. Full texture, row 0 = top, so the
// texture coordinate of pattern point p is ((p − origin) / (pixel_size · (width, height))).
void render_carved_texture_rgba(const std::vector<Vec2>& outline, const CarveState& state, const DetailParams& params,
                                const FiberField& fiber, int32_t side, const PatternStyle& style,
                                std::vector<uint8_t>& rgba);
void write_carved_texture_png(const std::string& path, const std::vector<Vec2>& outline, const CarveState& state,
                              const DetailParams& params, const FiberField& fiber, int32_t side,
                              const PatternStyle& style = {});

}  // namespace pt
