// The carving system (paper §6; docs/architecture.md "Details"). See carving.hpp for the side-label
// map design.
#include "systems/carving/carving.hpp"

#include "systems/common/pattern_geometry.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <memory>

namespace pt {
namespace {

inline int32_t sign(int64_t v) { return (v > 0) - (v < 0); }

inline bool inside(const DetailParams& p, int32_t i, int32_t j) {
  return i >= 0 && j >= 0 && i < p.width && j < p.height;
}

// G_i and T_fiber of eq. 7 for one coarse segment, with the per-segment constants hoisted.
struct Weight {
  const FiberField& fiber;
  const DetailParams& params;
  Vec2 a, ab;
  double inv_len2 = 0, inv_2s2 = 0;
  bool same_grid = false;

  Weight(const FiberField& f, const DetailParams& p, const Vec2& a_, const Vec2& b_)
      : fiber(f), params(p), a(a_), ab(b_ - a_) {
    const double len2 = ab.squaredNorm();
    inv_len2 = len2 > 0 ? 1.0 / len2 : 0.0;
    inv_2s2 = 1.0 / (2.0 * std::max(p.sigma, 1e-12) * std::max(p.sigma, 1e-12));
    // When the carving texture is the fiber texture (the engine's default), T_fiber at a pixel is the
    // texel itself; otherwise (Fig. 19's other resolutions) sample the same field bilinearly.
    same_grid = f.origin == p.origin && f.pixel_size == p.pixel_size;
  }

  double operator()(int32_t i, int32_t j) const {
    const Vec2 c = pixel_centre(params, i, j);
    const double t = std::clamp((c - a).dot(ab) * inv_len2, 0.0, 1.0);
    const double d2 = (c - (a + t * ab)).squaredNorm();  // distance to the segment, m²
    const double g = std::exp(-d2 * inv_2s2);
    const double tf = same_grid ? fiber_texel(fiber, i, j) : fiber_sample(fiber, c);
    return (1.0 - params.omega) * tf + params.omega * g;
  }
};

// Writes labels with a one-tile cache: band runs walk along a column or row, mostly inside one tile.
class LabelWriter {
 public:
  LabelWriter(const DetailParams& p, CarveState& s) : params_(p), state_(s) {}

  // Never overwrites a path pixel: the broken fibres of an earlier segment stay broken.
  void side(int32_t i, int32_t j, uint16_t label) {
    if (!inside(params_, i, j)) return;
    uint16_t& l = at(i, j);
    if (l != kPathLabel) l = label;
  }
  void path(int32_t i, int32_t j) {
    if (inside(params_, i, j)) at(i, j) = kPathLabel;
  }

 private:
  uint16_t& at(int32_t i, int32_t j) {
    const uint32_t key = (static_cast<uint32_t>(j >> kTileBits) << 16) | static_cast<uint32_t>(i >> kTileBits);
    if (key != cached_key_ || cached_ == nullptr) {
      cached_key_ = key;
      cached_ = &tile(key);
    }
    return cached_->label[(j & (kTileSize - 1)) * kTileSize + (i & (kTileSize - 1))];
  }

  LabelTile& tile(uint32_t key) {
    auto it = std::lower_bound(state_.tile_keys.begin(), state_.tile_keys.end(), key);
    const size_t k = static_cast<size_t>(it - state_.tile_keys.begin());
    if (it != state_.tile_keys.end() && *it == key) return *state_.tiles[state_.tile_slot[k]];
    state_.tile_keys.insert(it, key);
    state_.tile_slot.insert(state_.tile_slot.begin() + static_cast<std::ptrdiff_t>(k),
                            static_cast<int32_t>(state_.tiles.size()));
    state_.tiles.push_back(std::make_unique<LabelTile>());
    return *state_.tiles.back();
  }

  const DetailParams& params_;
  CarveState& state_;
  uint32_t cached_key_ = 0;
  LabelTile* cached_ = nullptr;
};

// Label the band of one carved path (pixels from detail_path for the coarse segment a → b).
//
// The path is monotone along the dominant axis of its segment (detail_path never steps back along it),
// so each line across that axis ("column") meets the path in one contiguous run [lo, hi]. Pixels past
// either end of the run are on one side of the whole path: this is exactly the partition a 4-connected
// flood fill would find with the 8-connected path as the barrier, at O(band) cost and with no distance
// computations. In each column the band reaches the support strip's edge on both sides of the coarse
// segment (so every pixel a strip of support_strip_width can draw carries its side, §6.2 / Fig. 11),
// and at least 2 pixels past the path where it wanders beyond the strip.
void label_band(const DetailParams& params, const Vec2& a, const Vec2& b, const std::vector<Pixel>& path,
                int32_t tear, CarveState& state) {
  LabelWriter w(params, state);
  const Pixel pa = path.front(), pb = path.back();
  const bool x_dom = std::abs(pb[0] - pa[0]) >= std::abs(pb[1] - pa[1]);
  const int dom = x_dom ? 0 : 1, perp = 1 - dom;
  const int32_t sdom = sign(static_cast<int64_t>(pb[dom]) - pa[dom]);
  if (sdom == 0) {  // the whole segment inside one pixel: only its broken fibres
    for (const Pixel& p : path) w.path(p[0], p[1]);
    return;
  }
  const bool labelled = tear >= 0 && tear <= kMaxLabelledTear;

  // Coarse segment in pixel-centre units (pixel k's centre at k), perp coordinate as a function of dom.
  const Vec2 ua = (a - params.origin) / params.pixel_size - Vec2(0.5, 0.5);
  const Vec2 ub = (b - params.origin) / params.pixel_size - Vec2(0.5, 0.5);
  const double span = ub[dom] - ua[dom];
  const double slope = std::abs(span) > 1e-9 ? (ub[perp] - ua[perp]) / span : 0.0;
  double dev = 0;
  for (const Pixel& p : path) dev = std::max(dev, std::abs(p[perp] - (ua[perp] + (p[dom] - ua[dom]) * slope)));
  state.band_px = std::max(state.band_px, static_cast<int32_t>(std::ceil(dev)));
  // A perpendicular distance w from the segment is w·sqrt(1 + slope²) along the column (≤ w·√2, as the
  // axis is dominant); one more pixel for the rounding of the strip's edge.
  const double reach = support_strip_width(params) / params.pixel_size * std::sqrt(1.0 + slope * slope) + 1.0;

  // Left normal of the direction (sx, sy) is (−sy, sx): for an x-dominant path moving +x, +y is left;
  // for a y-dominant path moving +y, +x is right.
  const bool plus_is_left = x_dom ? sdom > 0 : sdom < 0;
  const uint16_t plus = labelled ? static_cast<uint16_t>(side_label(tear, plus_is_left)) : kPaperLabel;
  const uint16_t minus = labelled ? static_cast<uint16_t>(side_label(tear, !plus_is_left)) : kPaperLabel;

  auto put = [&](int32_t u, int32_t q, uint16_t label) {
    if (x_dom) w.side(u, q, label);
    else w.side(q, u, label);
  };
  size_t k = 0;
  while (k < path.size()) {
    const int32_t u = path[k][dom];
    int32_t lo = path[k][perp], hi = lo;
    for (; k < path.size() && path[k][dom] == u; ++k) {
      lo = std::min(lo, path[k][perp]);
      hi = std::max(hi, path[k][perp]);
      w.path(path[k][0], path[k][1]);
    }
    if (!labelled) continue;
    const double c = ua[perp] + (u - ua[dom]) * slope;
    const int32_t from = std::min(lo - 2, static_cast<int32_t>(std::floor(c - reach)));
    const int32_t to = std::max(hi + 2, static_cast<int32_t>(std::ceil(c + reach)));
    for (int32_t q = from; q < lo; ++q) put(u, q, minus);
    for (int32_t q = hi + 1; q <= to; ++q) put(u, q, plus);
  }
}

void carve_segment(const FiberField& fiber, const DetailParams& params, Tear& tear, size_t seg,
                   CarveState& state) {
  const Vec2 a = tear.tips[seg], b = tear.tips[seg + 1];
  std::vector<Pixel>& path = state.scratch_path;
  detail_path(fiber, params, a, b, path);

  // Pattern points: tip i exactly, the centres of the interior pixels, tip i+1 exactly. A segment
  // continues the previous one from its last point (tip i), so the joint is not repeated; a branch's
  // first tip is its start point on the parent's lip (a parent tip in practice, which the parent's detail
  // passes through exactly), so the branch's detail starts on the parent's.
  if (tear.detail.empty() || tear.detail.back() != a) tear.detail.push_back(a);
  for (size_t k = 1; k + 1 < path.size(); ++k) tear.detail.push_back(pixel_centre(params, path[k][0], path[k][1]));
  if (b != a) tear.detail.push_back(b);

  label_band(params, a, b, path, tear.id, state);
  state.carved_segments += 1;
  state.path_pixels += static_cast<int64_t>(path.size());
}

}  // namespace

Pixel pixel_of(const DetailParams& params, const Vec2& p) {
  const Vec2 u = (p - params.origin) / params.pixel_size;
  const int32_t i = static_cast<int32_t>(std::floor(std::clamp(u.x(), -1.0, static_cast<double>(params.width))));
  const int32_t j = static_cast<int32_t>(std::floor(std::clamp(u.y(), -1.0, static_cast<double>(params.height))));
  return {std::clamp(i, 0, std::max(0, params.width - 1)), std::clamp(j, 0, std::max(0, params.height - 1))};
}

Vec2 pixel_centre(const DetailParams& params, int32_t i, int32_t j) {
  return params.origin + Vec2((i + 0.5) * params.pixel_size, (j + 0.5) * params.pixel_size);
}

double carving_weight(const FiberField& fiber, const DetailParams& params, const Vec2& a, const Vec2& b,
                      int32_t i, int32_t j) {
  return Weight(fiber, params, a, b)(i, j);
}

// Greedy walk of §6.1 on T (eq. 7). Candidates are the 8-neighbours inside the texture that are
// strictly closer (Euclidean, in pixels) to b's pixel and do not step back along the segment's dominant
// axis (nor past b's pixel on it). Why:
//   - termination: the integer squared distance to b's pixel strictly decreases, and the diagonal move
//     towards b (sign dx, sign dy) is always a candidate, so the walk never stalls;
//   - length: moves along the dominant axis are at most |Δdom|; a pure cross move is only "closer" when
//     it goes towards b's cross coordinate, and moves away from it happen only on diagonal steps, so
//     there are at most |Δperp| + |Δdom| cross moves: ≤ 3 × Chebyshev(a, b) steps in total;
//   - Euclidean (not Chebyshev) keeps diagonal segments as free to wander as axis-aligned ones
//     (Chebyshev leaves a single candidate on the diagonal);
//   - monotone along the dominant axis: each column meets the path in one run, which makes the side
//     labelling exact and linear (label_band).
// Ties on T go to the neighbour closer to b, then to the first in a fixed neighbour order: deterministic.
void detail_path(const FiberField& fiber, const DetailParams& params, const Vec2& a, const Vec2& b,
                 std::vector<Pixel>& pixels) {
  static constexpr int32_t kMoves[8][2] = {{1, 0}, {1, 1}, {0, 1}, {-1, 1}, {-1, 0}, {-1, -1}, {0, -1}, {1, -1}};
  pixels.clear();
  const Pixel pa = pixel_of(params, a), pb = pixel_of(params, b);
  pixels.push_back(pa);
  const bool x_dom = std::abs(pb[0] - pa[0]) >= std::abs(pb[1] - pa[1]);
  const Weight weight(fiber, params, a, b);
  // Successive steps share candidates (a cross move's neighbours were the previous step's): a small
  // ring of recent evaluations saves about a third of the T_fiber evaluations, which dominate.
  constexpr int32_t kCache = 16;
  std::array<Pixel, kCache> cached_px;
  std::array<double, kCache> cached_t{};
  cached_px.fill(Pixel{INT32_MIN, INT32_MIN});
  int32_t next_slot = 0;
  auto weight_at = [&](int32_t i, int32_t j) {
    for (int32_t c = 0; c < kCache; ++c)
      if (cached_px[c][0] == i && cached_px[c][1] == j) return cached_t[c];
    const double t = weight(i, j);
    cached_px[next_slot] = {i, j};
    cached_t[next_slot] = t;
    next_slot = (next_slot + 1) % kCache;
    return t;
  };
  int32_t x = pa[0], y = pa[1];
  while (x != pb[0] || y != pb[1]) {
    const int64_t dx = pb[0] - x, dy = pb[1] - y;
    const int64_t d2 = dx * dx + dy * dy;
    const int32_t sdom = sign(x_dom ? dx : dy);
    int32_t best = -1;
    double best_t = 0;
    int64_t best_d2 = 0;
    for (int32_t k = 0; k < 8; ++k) {
      const int32_t mx = kMoves[k][0], my = kMoves[k][1];
      const int32_t mdom = x_dom ? mx : my;
      if (mdom != 0 && mdom != sdom) continue;
      const int64_t nd2 = (dx - mx) * (dx - mx) + (dy - my) * (dy - my);
      if (nd2 >= d2 || !inside(params, x + mx, y + my)) continue;
      const double t = weight_at(x + mx, y + my);
      if (best < 0 || t > best_t || (t == best_t && nd2 < best_d2)) {
        best = k;
        best_t = t;
        best_d2 = nd2;
      }
    }
    // best ≥ 0 always: the move (sign dx, sign dy) passes every filter (it stays in the box of pa, pb).
    x += kMoves[best][0];
    y += kMoves[best][1];
    pixels.push_back({x, y});
  }
}

void carve_new_segments(const FiberField& fiber, const DetailParams& params, std::vector<Tear>& tears,
                        CarveState& state) {
  for (Tear& tear : tears) {
    const int32_t segments = static_cast<int32_t>(tear.tips.size()) - 1;
    for (int32_t s = std::max(0, tear.carved_segments); s < segments; ++s) {
      carve_segment(fiber, params, tear, static_cast<size_t>(s), state);
      tear.carved_segments = s + 1;
    }
  }
}

uint16_t label_at(const CarveState& state, int32_t i, int32_t j) {
  if (i < 0 || j < 0) return kPaperLabel;
  const uint32_t key = (static_cast<uint32_t>(j >> kTileBits) << 16) | static_cast<uint32_t>(i >> kTileBits);
  auto it = std::lower_bound(state.tile_keys.begin(), state.tile_keys.end(), key);
  if (it == state.tile_keys.end() || *it != key) return kPaperLabel;
  const LabelTile& t = *state.tiles[state.tile_slot[static_cast<size_t>(it - state.tile_keys.begin())]];
  return t.label[(j & (kTileSize - 1)) * kTileSize + (i & (kTileSize - 1))];
}

bool pixel_visible(const CarveState& state, int32_t triangle_label, int32_t i, int32_t j) {
  if (triangle_label <= 0) return true;
  const int32_t l = label_at(state, i, j);
  if (l == kPaperLabel || l == kPathLabel) return true;
  if (label_tear(l) != label_tear(triangle_label)) return true;  // another tear's band: not ours to cut
  return l == triangle_label;
}

int32_t triangle_side(const Tear& tear, const Vec2& centroid) {
  if (tear.tips.size() < 2) return 0;
  size_t best = 0;
  double best_d2 = INFINITY;
  for (size_t s = 0; s + 1 < tear.tips.size(); ++s) {
    const double d2 = point_segment_distance2(centroid, tear.tips[s], tear.tips[s + 1]);
    if (d2 < best_d2) {
      best_d2 = d2;
      best = s;
    }
  }
  const Vec2 ab = tear.tips[best + 1] - tear.tips[best], ac = centroid - tear.tips[best];
  return side_label(tear.id, ab.x() * ac.y() - ab.y() * ac.x() > 0);
}

void assign_triangle_sides(const std::vector<Vec2>& rest, const std::vector<int32_t>& vertex_tear,
                           const std::vector<Tri>& tri, const std::vector<Tear>& tears,
                           std::vector<int32_t>& side) {
  side.assign(tri.size(), 0);
  for (size_t t = 0; t < tri.size(); ++t) {
    int32_t tear = -1;
    for (int32_t v : tri[t])
      if (vertex_tear[static_cast<size_t>(v)] >= 0) {
        tear = vertex_tear[static_cast<size_t>(v)];
        break;
      }
    if (tear < 0 || tear >= static_cast<int32_t>(tears.size())) continue;
    const Vec2 c = (rest[static_cast<size_t>(tri[t][0])] + rest[static_cast<size_t>(tri[t][1])] +
                    rest[static_cast<size_t>(tri[t][2])]) / 3.0;
    side[t] = triangle_side(tears[static_cast<size_t>(tear)], c);
  }
}

double support_strip_width(const DetailParams& params) {
  // The detail path stays within 4σ + 2 pixels of its coarse segment at the default ω (tested), so a strip
  // this wide shows all of it; the band labels cover the strip (label_band).
  return 4.0 * params.sigma + 2.0 * params.pixel_size;
}

int64_t bytes_used(const CarveState& state) {
  return static_cast<int64_t>(state.tiles.size() * sizeof(LabelTile) +
                              state.tiles.capacity() * sizeof(std::unique_ptr<LabelTile>) +
                              state.tile_keys.capacity() * sizeof(uint32_t) +
                              state.tile_slot.capacity() * sizeof(int32_t) +
                              state.scratch_path.capacity() * sizeof(Pixel));
}

}  // namespace pt
