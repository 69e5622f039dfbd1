// The carving system (paper §6; docs/architecture.md "Details"): detail path of eq. 7, side labels,
// visibility, memory.
#include "systems/carving/carving.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <queue>
#include <set>

namespace pt {
namespace {

// An A4-ish texture at 0.1 mm per pixel; the fiber field uses the same grid (as the engine does).
DetailParams params(double sigma = 1e-4) {
  DetailParams p;
  p.origin = Vec2(0, 0);
  p.pixel_size = 1e-4;
  p.width = 2100;
  p.height = 2970;
  p.sigma = sigma;
  p.omega = 0.5;
  return p;
}

FiberField fiber(uint64_t seed = 1) {
  FiberField f;
  f.seed = seed;
  f.feature_size = 0.004;
  f.origin = Vec2(0, 0);
  f.pixel_size = 1e-4;
  return f;
}

int32_t chebyshev(const Pixel& a, const Pixel& b) { return std::max(std::abs(a[0] - b[0]), std::abs(a[1] - b[1])); }

double segment_distance(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (p - (a + t * ab)).norm();
}

// Segments in every direction (axis-aligned, diagonal, steep, reversed), 2–8 mm.
std::vector<std::pair<Vec2, Vec2>> segments() {
  std::vector<std::pair<Vec2, Vec2>> s;
  for (int k = 0; k < 24; ++k) {
    const double angle = k * (2 * M_PI / 24) + 0.013 * k;
    const double len = 0.002 + 0.00025 * k;
    const Vec2 a(0.05 + 0.003 * k, 0.08 + 0.002 * k);
    s.push_back({a, a + len * Vec2(std::cos(angle), std::sin(angle))});
  }
  return s;
}

double mean_deviation(const FiberField& f, const DetailParams& p, const Vec2& a, const Vec2& b) {
  std::vector<Pixel> path;
  detail_path(f, p, a, b, path);
  double sum = 0;
  for (const Pixel& px : path) sum += segment_distance(pixel_centre(p, px[0], px[1]), a, b);
  return sum / static_cast<double>(path.size());
}

TEST(DetailPath, EightConnectedFromTipToTip) {
  const FiberField f = fiber();
  const DetailParams p = params();
  std::vector<Pixel> path;
  for (const auto& [a, b] : segments()) {
    detail_path(f, p, a, b, path);
    ASSERT_GE(path.size(), 1u);
    EXPECT_EQ(path.front(), pixel_of(p, a));
    EXPECT_EQ(path.back(), pixel_of(p, b));
    for (size_t k = 1; k < path.size(); ++k) ASSERT_EQ(chebyshev(path[k - 1], path[k]), 1);
    // Bounded by the pixel distance (carving.cpp: ≤ 3 × Chebyshev steps), and never revisits a pixel.
    EXPECT_LE(path.size() - 1, 3u * static_cast<size_t>(chebyshev(path.front(), path.back())));
    std::set<Pixel> unique(path.begin(), path.end());
    EXPECT_EQ(unique.size(), path.size());
  }
}

TEST(DetailPath, StaysNearTheCoarseSegment) {
  const FiberField f = fiber();
  for (double sigma : {1e-4, 3e-4}) {
    const DetailParams p = params(sigma);
    std::vector<Pixel> path;
    for (const auto& [a, b] : segments()) {
      detail_path(f, p, a, b, path);
      for (const Pixel& px : path)
        EXPECT_LE(segment_distance(pixel_centre(p, px[0], px[1]), a, b), 4 * sigma + 2 * p.pixel_size);
    }
  }
}

TEST(DetailPath, LargerSigmaIsRougher) {
  // Fig. 19: σ = 1 mm lets the fibres pull the path much further from the coarse segment than 0.1 mm.
  const FiberField f = fiber();
  double small = 0, large = 0;
  for (const auto& [a, b] : segments()) {
    small += mean_deviation(f, params(1e-4), a, b);
    large += mean_deviation(f, params(1e-3), a, b);
  }
  EXPECT_GT(large, 1.5 * small);
  EXPECT_GT(large / segments().size(), 1e-4);  // at least a pixel on average
}

TEST(DetailPath, SeedDeterminesThePath) {
  const DetailParams p = params();
  std::vector<Pixel> a1, a2, b1;
  int differ = 0;
  for (const auto& [a, b] : segments()) {
    detail_path(fiber(5), p, a, b, a1);
    detail_path(fiber(5), p, a, b, a2);
    detail_path(fiber(6), p, a, b, b1);
    EXPECT_EQ(a1, a2);
    differ += a1 != b1;
  }
  EXPECT_GT(differ, 12);
}

TEST(DetailPath, HugsTheTextureBorder) {
  // A tear along the sheet's edge: the walk never leaves the texture.
  const FiberField f = fiber();
  const DetailParams p = params();
  std::vector<Pixel> path;
  detail_path(f, p, Vec2(0.01, 0.00001), Vec2(0.02, 0.00002), path);
  for (const Pixel& px : path) {
    EXPECT_GE(px[1], 0);
    EXPECT_LT(px[1], p.height);
  }
  EXPECT_EQ(path.back(), pixel_of(p, Vec2(0.02, 0.00002)));
}

Tear make_tear(int32_t id, std::vector<Vec2> tips) {
  Tear t;
  t.id = id;
  t.tips = std::move(tips);
  t.start_uv = t.tips.front();
  return t;
}

TEST(Carving, DetailIsContinuousAcrossSegments) {
  const FiberField f = fiber();
  const DetailParams p = params();
  std::vector<Tear> tears{make_tear(0, {Vec2(0.02, 0.03), Vec2(0.025, 0.0312)})};
  CarveState state;
  carve_new_segments(f, p, tears, state);
  EXPECT_EQ(tears[0].carved_segments, 1);
  const size_t first = tears[0].detail.size();
  EXPECT_EQ(tears[0].detail.front(), tears[0].tips[0]);
  EXPECT_EQ(tears[0].detail.back(), tears[0].tips[1]);

  // The tear propagates (turning by 0.6 rad): only the new segment is carved, it starts where the first ended.
  tears[0].tips.push_back(Vec2(0.029, 0.0345));
  carve_new_segments(f, p, tears, state);
  const Tear& t = tears[0];
  EXPECT_EQ(t.carved_segments, 2);
  EXPECT_EQ(t.detail[first - 1], t.tips[1]);
  EXPECT_NE(t.detail[first], t.tips[1]);  // no duplicate joint
  EXPECT_EQ(t.detail.back(), t.tips[2]);
  for (size_t k = 1; k < t.detail.size(); ++k)
    EXPECT_EQ(chebyshev(pixel_of(p, t.detail[k - 1]), pixel_of(p, t.detail[k])), 1) << k;

  // Incremental carving equals carving everything at once.
  std::vector<Tear> once{make_tear(0, t.tips)};
  CarveState state_once;
  carve_new_segments(f, p, once, state_once);
  EXPECT_EQ(once[0].detail, t.detail);

  // A branch starting at the parent's tip 1 starts on the parent's detail.
  tears.push_back(make_tear(1, {t.tips[1], t.tips[1] + Vec2(0.001, -0.004)}));
  tears[1].parent = 0;
  carve_new_segments(f, p, tears, state);
  EXPECT_NE(std::find(tears[0].detail.begin(), tears[0].detail.end(), tears[1].detail.front()),
            tears[0].detail.end());
  EXPECT_EQ(tears[1].detail.back(), tears[1].tips.back());
}

// Side of q with respect to the detail polyline (independent oracle): the sign at the nearest point,
// with the vertex pseudo-normal (sum of the adjacent segments' unit left normals) when that is a vertex.
int32_t polyline_side(const std::vector<Vec2>& poly, const Vec2& q) {
  double best = INFINITY;
  double side = 0;
  for (size_t k = 0; k + 1 < poly.size(); ++k) {
    const Vec2 a = poly[k], ab = poly[k + 1] - a;
    const double t = std::clamp((q - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    const double d = (q - (a + t * ab)).norm();
    if (d >= best - 1e-12) continue;
    best = d;
    auto left_normal = [&](size_t s) {
      const Vec2 e = (poly[s + 1] - poly[s]).normalized();
      return Vec2(-e.y(), e.x());
    };
    Vec2 n = left_normal(k);
    if (t <= 0 && k > 0) n += left_normal(k - 1);
    if (t >= 1 && k + 2 < poly.size()) n += left_normal(k + 1);
    side = (q - (a + t * ab)).dot(n);
  }
  if (best < 1e-9) return 0;
  return side > 0 ? 1 : -1;
}

// 4-connected flood fill over labelled, non-path pixels from a seed; returns the labels met.
std::set<int32_t> flood_labels(const CarveState& s, Pixel seed, int32_t limit) {
  std::set<int32_t> labels;
  std::set<Pixel> seen{seed};
  std::queue<Pixel> q;
  q.push(seed);
  while (!q.empty() && static_cast<int32_t>(seen.size()) < limit) {
    const Pixel c = q.front();
    q.pop();
    labels.insert(label_at(s, c[0], c[1]));
    for (const Pixel d : {Pixel{1, 0}, Pixel{-1, 0}, Pixel{0, 1}, Pixel{0, -1}}) {
      const Pixel n{c[0] + d[0], c[1] + d[1]};
      const uint16_t l = label_at(s, n[0], n[1]);
      if (l == kPaperLabel || l == kPathLabel || seen.count(n)) continue;
      seen.insert(n);
      q.push(n);
    }
  }
  return labels;
}

TEST(Carving, BandHasOneSidePerPixelAndThePathSeparatesThem) {
  const FiberField f = fiber(3);
  for (const auto& [a, b] : segments()) {
    const DetailParams p = params();
    std::vector<Tear> tears{make_tear(4, {a, b})};
    CarveState state;
    carve_new_segments(f, p, tears, state);
    const int32_t left = side_label(4, true), right = side_label(4, false);
    // Every pixel within 2 px of the coarse segment (away from its ends) is labelled: path, left or right.
    const Vec2 dir = (b - a).normalized(), nrm(-dir.y(), dir.x());
    const double len = (b - a).norm();
    for (double s = 3e-4; s < len - 3e-4; s += 0.5e-4)
      for (double o = -2e-4; o <= 2e-4; o += 0.5e-4) {
        const Pixel px = pixel_of(p, a + s * dir + o * nrm);
        const uint16_t l = label_at(state, px[0], px[1]);
        EXPECT_TRUE(l == kPathLabel || l == left || l == right) << l;
      }
    // Seeds off the path on each side (inside the support strip): the fill never crosses the
    // 8-connected path, so each side's 4-connected component holds exactly one label, the geometric side.
    const Vec2 mid = 0.5 * (a + b);
    const double w = support_strip_width(p);
    const Pixel ls = pixel_of(p, mid + w * nrm), rs = pixel_of(p, mid - w * nrm);
    ASSERT_EQ(label_at(state, ls[0], ls[1]), polyline_side(tears[0].detail, pixel_centre(p, ls[0], ls[1])) > 0 ? left : right);
    ASSERT_EQ(label_at(state, rs[0], rs[1]), polyline_side(tears[0].detail, pixel_centre(p, rs[0], rs[1])) > 0 ? left : right);
    EXPECT_EQ(flood_labels(state, ls, 100000), std::set<int32_t>{label_at(state, ls[0], ls[1])});
    EXPECT_EQ(flood_labels(state, rs, 100000), std::set<int32_t>{label_at(state, rs[0], rs[1])});
  }
}

bool in_triangle(const Vec2& p, const Vec2& a, const Vec2& b, const Vec2& c) {
  auto cross = [](const Vec2& u, const Vec2& v) { return u.x() * v.y() - u.y() * v.x(); };
  return cross(b - a, p - a) >= 0 && cross(c - b, p - b) >= 0 && cross(a - c, p - c) >= 0;
}

TEST(Carving, RasterisedTrianglePairIsTransparentExactlyBeyondThePath) {
  const FiberField f = fiber(8);
  const DetailParams p = params(2e-4);
  const Vec2 A(0.0300, 0.0400), B(0.0360, 0.0412);
  std::vector<Tear> tears{make_tear(2, {A, B})};
  CarveState state;
  carve_new_segments(f, p, tears, state);
  const std::vector<Vec2>& detail = tears[0].detail;

  // Each lip is a rectangle of two triangles on AB (left above, right below), each triangle extended
  // across AB by the support strip (Fig. 11); the renderer gives a triangle the side of its centroid.
  const Vec2 dir = (B - A).normalized(), nrm(-dir.y(), dir.x());
  const double h = 0.003, w = support_strip_width(p);
  const Vec2 Au = A + h * nrm, Bu = B + h * nrm, Ad = A - h * nrm, Bd = B - h * nrm;
  const int32_t left = triangle_side(tears[0], (A + B + Bu) / 3.0);
  const int32_t right = triangle_side(tears[0], (B + A + Ad) / 3.0);
  ASSERT_EQ(left, side_label(2, true));
  ASSERT_EQ(triangle_side(tears[0], (A + Bu + Au) / 3.0), left);
  ASSERT_EQ(right, side_label(2, false));
  ASSERT_EQ(triangle_side(tears[0], (B + Ad + Bd) / 3.0), right);
  // Left lip with its strip: the rectangle from the strip's edge below AB to h above (and mirrored).
  auto covers_left = [&](const Vec2& q) {
    return in_triangle(q, A - w * nrm, B - w * nrm, Bu) || in_triangle(q, A - w * nrm, Bu, Au);
  };
  auto covers_right = [&](const Vec2& q) {
    return in_triangle(q, B + w * nrm, A + w * nrm, Ad) || in_triangle(q, B + w * nrm, Ad, Bd);
  };

  const Pixel lo = pixel_of(p, A - Vec2(0.005, 0.005)), hi = pixel_of(p, B + Vec2(0.005, 0.005));
  const Pixel ta = pixel_of(p, A), tb = pixel_of(p, B);
  int32_t transparent_left = 0, transparent_right = 0, checked = 0;
  for (int32_t j = lo[1]; j <= hi[1]; ++j)
    for (int32_t i = lo[0]; i <= hi[0]; ++i) {
      const Vec2 c = pixel_centre(p, i, j);
      const bool cl = covers_left(c), cr = covers_right(c);
      const bool vl = cl && pixel_visible(state, left, i, j), vr = cr && pixel_visible(state, right, i, j);
      transparent_left += cl && !vl;
      transparent_right += cr && !vr;
      // Every pixel of the pair is drawn by at least one triangle: no hole along the tear.
      if (cl || cr) {
        EXPECT_TRUE(vl || vr) << i << "," << j;
      }
      // Away from the tips (where the tear is open-ended), compare with the polyline oracle.
      if (i < std::min(ta[0], tb[0]) + 2 || i > std::max(ta[0], tb[0]) - 2) continue;
      if (!cl || !cr) continue;
      ++checked;
      const int32_t s = polyline_side(detail, c);
      if (label_at(state, i, j) == kPathLabel) {
        EXPECT_TRUE(vl && vr);  // the broken fibres show on both lips
      } else {
        EXPECT_EQ(vl, s > 0) << i << "," << j;  // left triangle: transparent exactly beyond the path
        EXPECT_EQ(vr, s < 0) << i << "," << j;
      }
    }
  EXPECT_GT(checked, 500);
  EXPECT_GT(transparent_left, 0);   // the path leaves the coarse edge, so each lip hides something
  EXPECT_GT(transparent_right, 0);
  // Triangles not along this tear (or along another) are never cut by it.
  for (int32_t i = ta[0]; i <= tb[0]; ++i)
    for (int32_t j = lo[1]; j <= hi[1]; ++j) {
      EXPECT_TRUE(pixel_visible(state, 0, i, j));
      EXPECT_TRUE(pixel_visible(state, side_label(7, true), i, j));
    }
}

TEST(Carving, TriangleSidesFromLipVertices) {
  const Tear t = make_tear(0, {Vec2(0, 0), Vec2(1, 0), Vec2(2, 1)});
  const std::vector<Vec2> rest{Vec2(0.5, 0), Vec2(1.5, 0.5), Vec2(0.8, 1), Vec2(0.9, -1), Vec2(5, 5)};
  const std::vector<int32_t> vt{0, 0, -1, -1, -1};
  const std::vector<Tri> tri{{0, 1, 2}, {0, 3, 1}, {2, 3, 4}};
  std::vector<Tear> tears{t};
  std::vector<int32_t> side;
  assign_triangle_sides(rest, vt, tri, tears, side);
  EXPECT_EQ(side, (std::vector<int32_t>{side_label(0, true), side_label(0, false), 0}));
}

TEST(Carving, MemoryGrowsWithTheTearNotTheTexture) {
  // A 5 cm tear in 10 segments of 5 mm, slightly curved, on an A4 texture.
  const FiberField f = fiber();
  const DetailParams p = params();
  std::vector<Vec2> tips{Vec2(0.0, 0.1)};
  for (int k = 1; k <= 10; ++k) tips.push_back(tips.back() + 0.005 * Vec2(std::cos(0.05 * k), std::sin(0.05 * k)));
  std::vector<Tear> tears{make_tear(0, tips)};
  CarveState state;
  carve_new_segments(f, p, tears, state);
  const int64_t bytes = bytes_used(state);
  EXPECT_LT(bytes, static_cast<int64_t>(0.05 * p.width * p.height));
  EXPECT_LT(bytes, static_cast<int64_t>(0.05 * 2048 * 1476));  // also against the paper's A4 texture
  EXPECT_GT(bytes, 0);

  // A second tear elsewhere leaves the first one's labels untouched.
  std::map<Pixel, uint16_t> before;
  const Pixel a = pixel_of(p, tips[3]);
  for (int32_t j = a[1] - 10; j <= a[1] + 10; ++j)
    for (int32_t i = a[0] - 10; i <= a[0] + 10; ++i) before[{i, j}] = label_at(state, i, j);
  tears.push_back(make_tear(1, {Vec2(0.15, 0.2), Vec2(0.155, 0.21)}));
  carve_new_segments(f, p, tears, state);
  for (const auto& [px, l] : before) EXPECT_EQ(label_at(state, px[0], px[1]), l);
}

}  // namespace
}  // namespace pt
