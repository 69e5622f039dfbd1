// The carving system (paper §6, docs/architecture.md "Details"): the fine tear path between successive coarse
// tips, and the per-pixel side labels that let a coarse mesh show a detailed torn edge.
//
// Detail path (§6.1, eq. 7): in texture pixels, T = (1 − ω) T_fiber + ω G_i, G_i a Gaussian (σ, meters)
// of the distance to the coarse segment; from tip i's pixel, step greedily to the 8-neighbour closer to
// tip i+1's pixel with the largest T.
//
// Texture carving (§6.2). The paper keeps two textures T_left / T_right per tear. We keep ONE sparse
// side-label map for all tears instead, because:
//   - memory: per-tear full textures cost 2 × W × H × 4 bytes per tear (A4 at 0.1 mm: ~50 MB per tear),
//     and a batch of 1 000 sheets would multiply that; the label map stores 2 bytes per pixel only in
//     32 × 32 tiles touched by a tear's band, so it grows with the tears' neighbourhood (a 5 cm tear:
//     tens of kB), never with tears × texture size;
//   - incrementality: a new segment writes only the pixels of its band; no texture copy when a tear
//     propagates or branches (the paper copies the parent's textures for a branch);
//   - the renderer needs one paper texture plus this map (or the per-side RGBA textures baked from it
//     by engine/texture_export for OBJ export), and a triangle just carries a side label.
#pragma once

#include "components/sheet.hpp"
#include "systems/tearing/fiber_field.hpp"

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

namespace pt {

// The texture frame and the parameters of eq. 7. The texture spans the outline's bounding box from
// `origin`, with square pixels of `pixel_size` (pixel (i, j) covers origin + [i, i+1) × [j, j+1) · size).
struct DetailParams {
  Vec2 origin = Vec2::Zero();
  double pixel_size = 1e-4;   // m (default of docs/architecture.md "Details": ~0.1 mm)
  int32_t width = 0, height = 0;
  double sigma = 1e-4;        // σ of G_i, m
  double omega = 0.5;         // ω of eq. 7
};

using Pixel = std::array<int32_t, 2>;

// Side labels (uint16 per pixel). 0: untouched paper, visible from every triangle.
constexpr uint16_t kPaperLabel = 0;
// A pixel of a detailed path: the broken fibres, visible from both lips (so no gap opens at rest).
constexpr uint16_t kPathLabel = 0xFFFF;
// Largest tear id a label can encode.
constexpr int32_t kMaxLabelledTear = (0xFFFE - 2) / 2;

// Label of the pixels (and triangles) on the left / right of tear `tear` (left: cross(direction, p) > 0).
inline int32_t side_label(int32_t tear, bool left) { return 2 * tear + (left ? 1 : 2); }
// The tear of a side label (label ≥ 1 and ≠ kPathLabel).
inline int32_t label_tear(int32_t label) { return (label - 1) / 2; }
inline bool label_is_left(int32_t label) { return (label & 1) == 1; }

constexpr int32_t kTileBits = 5;  // 32 × 32 pixels per tile
constexpr int32_t kTileSize = 1 << kTileBits;

struct LabelTile {
  std::array<uint16_t, kTileSize * kTileSize> label{};  // row-major, [ly * kTileSize + lx]
};

// Sparse side-label map: tiles allocated on demand, kept in a sorted key vector (binary search, few
// tiles, deterministic iteration order, exact memory accounting).
struct CarveState {
  std::vector<uint32_t> tile_keys;   // (ty << 16) | tx, ascending
  std::vector<int32_t> tile_slot;    // tile_keys[k] lives in tiles[tile_slot[k]]
  std::vector<std::unique_ptr<LabelTile>> tiles;  // stable addresses (a writer caches one)
  int32_t band_px = 0;               // largest offset of a detail path from its coarse segment, pixels
  int64_t carved_segments = 0;       // statistics
  int64_t path_pixels = 0;
  // Scratch reused between calls (no allocation per segment once warm).
  std::vector<Pixel> scratch_path;
};

// Pixel containing pattern point p, clamped to the texture.
Pixel pixel_of(const DetailParams& params, const Vec2& p);
// Pattern position of a pixel's centre.
Vec2 pixel_centre(const DetailParams& params, int32_t i, int32_t j);

// T of eq. 7 at pixel (i, j) for the coarse segment a → b (pattern meters).
double carving_weight(const FiberField& fiber, const DetailParams& params, const Vec2& a, const Vec2& b,
                      int32_t i, int32_t j);

// The greedy detail path (§6.1) from a's pixel to b's pixel, both included, 8-connected; `pixels` is
// overwritten. Terminates in at most 3 × Chebyshev(a, b) steps (see carving.cpp).
void detail_path(const FiberField& fiber, const DetailParams& params, const Vec2& a, const Vec2& b,
                 std::vector<Pixel>& pixels);

// Carve every coarse segment not yet carved (tear.carved_segments < tips.size() − 1): append its detail
// path to tear.detail (pattern meters; the first point of a tear is tips[0], each segment ends exactly at
// its tip, interior points are pixel centres, no duplicate joints) and label the pixels of its band.
void carve_new_segments(const FiberField& fiber, const DetailParams& params, std::vector<Tear>& tears,
                        CarveState& state);

// Side label of a pixel (kPaperLabel outside the tiles or the texture).
uint16_t label_at(const CarveState& state, int32_t i, int32_t j);

// Whether a triangle with side label `triangle_label` (0: not along a tear) shows pixel (i, j):
// transparent only where the pixel is labelled the other side of the same tear, i.e. beyond the
// detailed path.
bool pixel_visible(const CarveState& state, int32_t triangle_label, int32_t i, int32_t j);

// Side label a triangle with pattern centroid `centroid` takes along `tear`: the side of the nearest
// coarse segment (0 if the tear has no segment yet). Triangles along a tear lie on one side of its
// coarse path, and the detailed path stays within the support strip of it, so this matches the pixels.
int32_t triangle_side(const Tear& tear, const Vec2& centroid);

// Fill `side` (one per triangle) for a mesh: triangles with a corner on a tear's lip (vertex_tear ≥ 0)
// take triangle_side of that tear, the others 0. Inputs are the Vertices/Triangles arrays.
void assign_triangle_sides(const std::vector<Vec2>& rest, const std::vector<int32_t>& vertex_tear,
                           const std::vector<Tri>& tri, const std::vector<Tear>& tears,
                           std::vector<int32_t>& side);

// Width of the support strip (§6.2, Fig. 11) by which triangles along a tear are extended across their
// coarse edge so details beyond it are drawn, meters (4σ + 2 pixels). Every pixel such a strip covers
// along a carved segment carries a side label.
double support_strip_width(const DetailParams& params);

// Heap bytes held by the label map (for memory reports).
int64_t bytes_used(const CarveState& state);

}  // namespace pt
