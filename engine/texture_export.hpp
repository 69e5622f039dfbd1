// PNG output of the paper texture and its carving (paper §6.2, §7.4; docs/architecture.md "Details"): the 2D
// pattern with the detailed tears at texture resolution (`--png`, Fig. 19), the per-side RGBA textures whose
// pixels beyond the detailed path are transparent (`--obj`), and a plain RGBA writer others reuse.
#pragma once

#include "components/sheet.hpp"
#include "systems/carving/carving.hpp"
#include "systems/tearing/fiber_field.hpp"

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
  // Paper brightness varies by ±fiber/2 with T_fiber. Office paper's formation shows at a few percent;
  // ±11% (0.22) read as parchment's blotches (docs/fig19.md).
  double fiber = 0.06;
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

// Read an 8-bit PNG (any colour type libpng can expand) as RGBA8, row 0 = top. Throws std::runtime_error.
void read_rgba_png(const std::string& path, int32_t& width, int32_t& height, std::vector<uint8_t>& rgba);

// --- Carved atlas for textured OBJ export (`--obj`) ------------------------------------------------------
//
// Choice: the untouched paper is ONE full texture (paper.png, written once per run; every triangle not
// along a tear maps into it), and every tear side present gets a PATCH of one shared carved atlas: the
// window of the texture covering that side's lip triangles and their support strips, with alpha 0 on the
// pixels beyond the detailed path for that side. Why not the alternatives:
//   - one full-size RGBA texture per side label (the paper's T_left/T_right): 2 × W × H × 4 bytes per tear
//     (A4 at 0.1 mm: 25 MB per tear) and one large PNG rewrite per side whenever a segment is carved;
//   - one single texture with uv = pattern position: a pixel beyond the coarse edge must be opaque for
//     the support strip of one lip and transparent for the other lip's triangle that covers the same
//     pattern point, which one texel cannot be; without strips the detail beyond the coarse edge is lost
//     and a gap opens at rest wherever the detailed path leaves the coarse one.
// The atlas therefore grows with the tears' neighbourhood (like the label map), and it is rewritten only
// when carving or the lip triangles changed.
struct AtlasPatch {
  int32_t label = 0;   // side label (≥ 1)
  PixelRect rect;      // window of the texture (pixels, y up)
  int32_t x = 0, y = 0;  // top-left corner of the patch in the atlas image (y down)
};

struct CarvedAtlas {
  int32_t width = 0, height = 0;
  std::vector<AtlasPatch> patches;  // ascending label
  const AtlasPatch* find(int32_t label) const;
  // Texture coordinate (OBJ convention: v up from the image's bottom row) of pattern point p in the patch.
  Vec2 uv(const DetailParams& params, const AtlasPatch& patch, const Vec2& p) const;
  bool operator==(const CarvedAtlas& o) const;
};

// Shelf-packs the windows (label, rect) in the given order into an atlas no wider than the widest window
// or `max_width`, whichever is larger. Deterministic.
CarvedAtlas pack_carved_atlas(const std::vector<std::pair<int32_t, PixelRect>>& windows, int32_t max_width = 4096);

// Whether a pixel shows on the triangles and support strips of side `label`: the side-label rule of
// pixel_visible, plus, for unlabelled pixels (past the carved band, e.g. a segment not carved yet), hidden
// when they lie across that side's coarse path within `reach` meters of it (a strip must not draw paper
// over the other lip).
bool side_pixel_visible(const std::vector<Tear>& tears, const CarveState& state, const DetailParams& params,
                        int32_t label, int32_t i, int32_t j, double reach);

// The atlas image (width × height RGBA8, row 0 = top): paper × fibres in each patch, alpha 0 outside the
// outline, beyond the detailed path of the patch's side, and between patches. Cost O(atlas pixels).
void render_carved_atlas(const CarvedAtlas& atlas, const std::vector<Vec2>& outline, const std::vector<Tear>& tears,
                         const CarveState& state, const DetailParams& params, const FiberField& fiber,
                         const PatternStyle& style, std::vector<uint8_t>& rgba);

}  // namespace pt
