// Remeshing (paper §5.3, Fig. 8, appendix A; docs/tearing.md "The cut"): cutting tear segments into
// hand-built regular and jittered grids of a rectangle with a notch, checking the mesh invariants after
// every cut.
#include "systems/mesh/remeshing.hpp"
#include "systems/common/topology.hpp"
#include "tests/test_meshes.hpp"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <cstdio>
#include <random>
#include <sstream>

using namespace pt;

namespace {

constexpr double kW = 0.2, kH = 0.2;

// 3D positions are an affine image of the pattern, so barycentric interpolation of new vertices must
// reproduce the same map exactly (up to rounding).
Vec3 affine3(const Vec2& r) { return Vec3(0.9 * r.x() + 0.1 * r.y() + 0.01, 0.2 * r.x() + 0.8 * r.y(), 0.3 * r.x() - 0.4 * r.y()); }

// Rectangle kW x kH as an nx x ny grid (alternating diagonals), interior vertices jittered by up to
// `jitter` cells, and a notch: the middle vertex of the top edge pushed down by half a cell.
Sheet make_grid(int nx, int ny, double jitter, uint64_t seed) {
  Sheet s;
  const double dx = kW / nx, dy = kH / ny;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  s.verts.resize((nx + 1) * (ny + 1));
  auto id = [&](int i, int j) { return j * (nx + 1) + i; };
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      Vec2 r(i * dx, j * dy);
      if (i > 0 && i < nx && j > 0 && j < ny) r += Vec2(u(rng) * jitter * dx, u(rng) * jitter * dy);
      if (i == nx / 2 && j == ny) r.y() -= 0.5 * dy;  // the notch
      s.verts.rest[id(i, j)] = r;
    }
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      if ((i + j) % 2 == 0) {
        s.tris.tri.push_back(Tri{a, b, c});
        s.tris.tri.push_back(Tri{a, c, d});
      } else {
        s.tris.tri.push_back(Tri{a, b, d});
        s.tris.tri.push_back(Tri{b, c, d});
      }
    }
  s.tris.resize(static_cast<int32_t>(s.tris.tri.size()));
  for (int32_t v = 0; v < s.verts.size(); ++v) s.verts.x[v] = affine3(s.verts.rest[v]);
  refresh_after_topology_change(s);
  return s;
}

int32_t notch_vertex(int nx, int ny) { return ny * (nx + 1) + nx / 2; }

// Checks the invariants of docs/architecture.md "Data and its invariants" plus the tear-specific ones
// after a cut.
void expect_valid_after_cut(const Sheet& s, double area, const CutResult& res, int32_t tear) {
  ASSERT_EQ(check_mesh_invariants(s, area), "");
  for (int32_t v = 0; v < s.verts.size(); ++v) {
    ASSERT_TRUE(s.verts.rest[v].allFinite() && s.verts.x[v].allFinite()) << v;
    ASSERT_LT((s.verts.x[v] - affine3(s.verts.rest[v])).norm(), 1e-12) << v;
  }
  if (res.cut && !res.reached_boundary) {
    const int32_t t = res.tip_vertex;
    ASSERT_GE(t, 0);
    ASSERT_LT(t, s.verts.size());
    EXPECT_TRUE(s.verts.flags[t] & kBoundary);
    EXPECT_TRUE(s.verts.flags[t] & kInward);
    EXPECT_NEAR(interior_pattern_angle(s.topo, s.verts.rest, t), 2 * std::numbers::pi, 1e-9);
    EXPECT_EQ(s.verts.tear[t], tear);
    EXPECT_EQ(s.verts.rest[t], res.end);
  }
}

// Vertices of the tear, grouped by pattern position: every lip vertex but the tip comes as a pair.
std::map<std::pair<double, double>, int> tear_positions(const Sheet& s, int32_t tear) {
  std::map<std::pair<double, double>, int> m;
  for (int32_t v = 0; v < s.verts.size(); ++v)
    if (s.verts.tear[v] == tear) ++m[{s.verts.rest[v].x(), s.verts.rest[v].y()}];
  return m;
}

int count_at(const Sheet& s, const Vec2& r) {
  int n = 0;
  for (const Vec2& q : s.verts.rest) n += q == r;
  return n;
}

// A boundary vertex, u in [0, 1) choosing among them in id order (the topology's list, which
// check_mesh_invariants compares with a full rebuild after every cut).
int32_t random_boundary_vertex(const Sheet& s, double u) {
  const std::vector<int32_t>& boundary = s.topo.boundary_vertices;
  return boundary[static_cast<size_t>(u * boundary.size()) % boundary.size()];
}

// Unit pattern direction from boundary vertex p to the next one along the boundary (sheet on the left).
Vec2 boundary_tangent(const Sheet& s, int32_t p) {
  return (s.verts.rest[s.topo.boundary_next[p]] - s.verts.rest[p]).normalized();
}

double segment_param(const Vec2& p, const Vec2& q, const Vec2& a, const Vec2& b, bool& hit) {
  auto cr = [](const Vec2& u, const Vec2& w) { return u.x() * w.y() - u.y() * w.x(); };
  const Vec2 d = q - p, e = b - a;
  const double den = cr(d, e);
  hit = false;
  if (den == 0) return 0;
  const double t = cr(a - p, e) / den, s = cr(a - p, d) / den;
  hit = t > 0 && t < 1 && s >= 0 && s <= 1;
  return t;
}

}  // namespace

TEST(Remeshing, GridIsValid) {
  for (double jitter : {0.0, 0.3}) {
    Sheet s = make_grid(8, 8, jitter, 7);
    EXPECT_EQ(check_mesh_invariants(s, kW * kH - 0.5 * (kW / 8) * (kH / 16) * 2 / 1.0), "");
    EXPECT_TRUE(s.verts.flags[notch_vertex(8, 8)] & kInward);
  }
}

TEST(Remeshing, StraightCutFromNotch) {
  for (double jitter : {0.0, 0.25}) {
    Sheet s = make_grid(8, 8, jitter, 3);
    const double area = total_rest_area(s.tris);
    const int32_t p = notch_vertex(8, 8);
    const Vec2 next(0.107, 0.113);
    const CutResult res = cut_tear_segment(p, next, Vec2::Zero(), 0, RemeshParams{}, s);
    ASSERT_TRUE(res.cut);
    EXPECT_FALSE(res.reached_boundary);
    expect_valid_after_cut(s, area, res, 0);
    // The tip is where it was asked to be, up to the snap radius (a quarter of the local edge).
    EXPECT_LT((res.end - next).norm(), 0.25 * 0.025 * 1.5);
    EXPECT_EQ(s.topo.piece_count, 1);
    // Two separate lips: every tear vertex but the tip is paired with a copy at the same position.
    const auto pos = tear_positions(s, 0);
    EXPECT_GE(pos.size(), 2u);
    for (const auto& [r, n] : pos) {
      const bool tip = r.first == res.end.x() && r.second == res.end.y();
      EXPECT_EQ(n, tip ? 1 : 2) << r.first << "," << r.second;
    }
    EXPECT_EQ(res.new_vertices, s.verts.size() - 81);
    // p stays (no previous direction): the notch corner now exists twice, both on the boundary.
    EXPECT_EQ(count_at(s, s.verts.rest[p]), 2);
  }
}

TEST(Remeshing, EndSnapsToNearbyVertex) {
  Sheet s = make_grid(8, 8, 0.0, 1);
  const double area = total_rest_area(s.tris);
  const int32_t target = 5 * 9 + 4;  // vertex (4, 5) at (0.1, 0.125)
  const Vec2 next = s.verts.rest[target] + Vec2(0.002, -0.001);
  const int32_t n0 = s.verts.size();
  const CutResult res = cut_tear_segment(notch_vertex(8, 8), next, Vec2::Zero(), 2, RemeshParams{}, s);
  ASSERT_TRUE(res.cut);
  expect_valid_after_cut(s, area, res, 2);
  EXPECT_EQ(res.tip_vertex, target);
  EXPECT_EQ(res.end, Vec2(0.1, 0.125));
  // The path runs down the grid column through (4, 7) and (4, 6) by snapping: only copies are created
  // (notch, (4, 7), (4, 6)), no split vertex.
  EXPECT_EQ(s.verts.size(), n0 + 3);
}

TEST(Remeshing, EndExactlyOnAnEdge) {
  Sheet s = make_grid(8, 8, 0.0, 1);
  const double area = total_rest_area(s.tris);
  const Vec2 next(0.1125, 0.125);  // middle of the horizontal edge (4,5)–(5,5)
  const CutResult res = cut_tear_segment(notch_vertex(8, 8), next, Vec2::Zero(), 0, RemeshParams{}, s);
  ASSERT_TRUE(res.cut);
  expect_valid_after_cut(s, area, res, 0);
  EXPECT_LT((res.end - next).norm(), 1e-12);
  EXPECT_GE(res.tip_vertex, 81);  // a new vertex on the edge (2 → 4), not inside a triangle
  int tip_triangles = 0;
  for (const Tri& t : s.tris.tri) tip_triangles += std::count(t.begin(), t.end(), res.tip_vertex);
  EXPECT_EQ(tip_triangles, 4);
}

// Issue 27, item 12 (a fuzz finding with tearing.snap 0): a segment ending exactly on an edge was
// inserted into its triangle, which left a triangle of zero area. With no snapping asked for, a point on
// an edge or at a vertex is still on it.
TEST(Remeshing, NoSnapStillPutsAnEndOnAnEdgeOnTheEdge) {
  RemeshParams no_snap;
  no_snap.snap_fraction = 0;
  {
    // The finding: a thin grid (one column of 14 cells), 4.3e-5 m inwards from vertex 11 on the right
    // edge at angle pi, i.e. along the interior edge 11-10: the end lies on that edge, 8e-5 of its
    // length from 11, so the cut stops where it stands (no edge split that close to an end).
    Sheet s = test::grid_sheet(0.51940147298342976, 0.35580883065316182, 1, 14, 0.39874368353850626, 3032845914u);
    const double area = total_rest_area(s.tris);
    ASSERT_EQ(check_mesh_invariants(s, area), "");
    const Vec2 next = s.verts.rest[11] + 4.3e-5 * Vec2(std::cos(std::numbers::pi), std::sin(std::numbers::pi));
    const CutResult res = cut_tear_segment(11, next, Vec2::Zero(), 0, no_snap, s);
    EXPECT_EQ(check_mesh_invariants(s, area), "");
    EXPECT_FALSE(res.cut);
  }
  {
    // The end in the middle of the horizontal edge (4,5)-(5,5) goes onto the edge, as with snapping.
    Sheet s = make_grid(8, 8, 0.0, 1);
    const double area = total_rest_area(s.tris);
    const CutResult res = cut_tear_segment(notch_vertex(8, 8), Vec2(0.1125, 0.125), Vec2::Zero(), 0, no_snap, s);
    ASSERT_TRUE(res.cut);
    expect_valid_after_cut(s, area, res, 0);
    int tip_triangles = 0;
    for (const Tri& t : s.tris.tri) tip_triangles += std::count(t.begin(), t.end(), res.tip_vertex);
    EXPECT_EQ(tip_triangles, 4);
  }
}

TEST(Remeshing, TurnKeepsPStraightRemovesP) {
  for (double jitter : {0.0, 0.2}) {
    Sheet s0 = make_grid(8, 8, jitter, 11);
    const double area = total_rest_area(s0.tris);
    const Vec2 d1 = Vec2(0.06, -1).normalized();
    const Vec2 start = s0.verts.rest[notch_vertex(8, 8)];
    const CutResult r1 = cut_tear_segment(notch_vertex(8, 8), start + 0.03 * d1, Vec2::Zero(), 0, RemeshParams{}, s0);
    ASSERT_TRUE(r1.cut);
    expect_valid_after_cut(s0, area, r1, 0);
    const Vec2 tip1 = r1.end;
    const Vec2 next = tip1 + 0.03 * d1;
    // Same segment twice: once continuing straight, once after a turn of 0.3 rad.
    Sheet straight = s0, turned = s0;
    const Vec2 prev_turned = Eigen::Rotation2Dd(0.3) * d1;
    const CutResult rs = cut_tear_segment(r1.tip_vertex, next, d1, 0, RemeshParams{}, straight);
    const CutResult rt = cut_tear_segment(r1.tip_vertex, next, prev_turned, 0, RemeshParams{}, turned);
    ASSERT_TRUE(rs.cut && rt.cut);
    expect_valid_after_cut(straight, area, rs, 0);
    expect_valid_after_cut(turned, area, rt, 0);
    EXPECT_EQ(rs.removed_vertices, 2);
    EXPECT_EQ(rt.removed_vertices, 0);
    EXPECT_EQ(count_at(straight, tip1), 0);  // p is gone from both lips
    EXPECT_EQ(count_at(turned, tip1), 2);    // p is a corner of both lips
    EXPECT_EQ(turned.verts.size(), straight.verts.size() + 2);
    EXPECT_EQ(rt.new_vertices, rs.new_vertices);
    EXPECT_EQ(turned.verts.size() - s0.verts.size(), rt.new_vertices);
  }
}

TEST(Remeshing, LongStraightTearAddsOnlyCrossings) {
  for (double jitter : {0.0, 0.25}) {
    Sheet s = make_grid(10, 10, jitter, 5);
    const Sheet original = s;
    const double area = total_rest_area(s.tris);
    const Vec2 d = Vec2(0.07, -1).normalized();
    int32_t tip = notch_vertex(10, 10);
    const Vec2 start = s.verts.rest[tip];
    Vec2 prev = Vec2::Zero();
    const int steps = 30;
    for (int k = 0; k < steps; ++k) {
      const Vec2 next = start + (k + 1) * 0.004 * d;
      const CutResult r = cut_tear_segment(tip, next, prev, 0, RemeshParams{}, s);
      if (!r.cut) {
        std::vector<int32_t> fan;
        for (int32_t t = 0; t < s.tris.size(); ++t)
          if (std::count(s.tris.tri[t].begin(), s.tris.tri[t].end(), tip)) fan.push_back(t);
        std::ostringstream os;
        os << "tip " << tip << " at " << s.verts.rest[tip].transpose() << " next " << next.transpose() << "\n";
        for (int32_t t : fan) {
          for (int32_t c : s.tris.tri[t]) os << c << " (" << s.verts.rest[c].transpose() << ") ";
          os << "\n";
        }
        ADD_FAILURE() << os.str();
      }
      ASSERT_TRUE(r.cut) << k;
      ASSERT_FALSE(r.reached_boundary);
      expect_valid_after_cut(s, area, r, 0);
      tip = r.tip_vertex;
      prev = d;
    }
    // Edges of the original mesh crossed by the whole straight tear.
    const Vec2 end = start + steps * 0.004 * d;
    int crossings = 0;
    std::vector<std::pair<int32_t, int32_t>> edges;
    for (const Tri& t : original.tris.tri)
      for (int i = 0; i < 3; ++i) edges.push_back({std::min(t[i], t[(i + 1) % 3]), std::max(t[i], t[(i + 1) % 3])});
    std::sort(edges.begin(), edges.end());
    edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
    for (const auto& [a, b] : edges) {
      bool hit = false;
      segment_param(start, end, original.verts.rest[a], original.verts.rest[b], hit);
      crossings += hit;
    }
    const int growth = s.verts.size() - original.verts.size();
    // Two vertices (one per lip) per crossing, plus the notch's copy and the tip; nothing per step.
    EXPECT_LE(growth, 2 * crossings + 2) << "crossings " << crossings;
    EXPECT_LT(growth, steps);
  }
}

TEST(Remeshing, CutAcrossTheSheetMakesTwoPieces) {
  for (double jitter : {0.0, 0.3}) {
    Sheet s = make_grid(8, 8, jitter, 9);
    const double area = total_rest_area(s.tris);
    const CutResult r = cut_tear_segment(notch_vertex(8, 8), Vec2(0.093, -0.05), Vec2::Zero(), 1, RemeshParams{}, s);
    ASSERT_TRUE(r.cut);
    EXPECT_TRUE(r.reached_boundary);
    EXPECT_EQ(r.tip_vertex, -1);
    expect_valid_after_cut(s, area, r, 1);
    EXPECT_NEAR(r.end.y(), 0.0, 1e-15);
    EXPECT_EQ(s.topo.piece_count, 2);
    double piece_area[2] = {0, 0};
    for (int32_t t = 0; t < s.tris.size(); ++t) piece_area[s.tris.piece[t]] += s.tris.rest_area[t];
    EXPECT_NEAR(piece_area[0] + piece_area[1], area, 1e-12);
    EXPECT_GT(piece_area[0], 0.35 * area);
    EXPECT_GT(piece_area[1], 0.35 * area);
    // Every tear vertex, including both ends, exists once per piece.
    for (const auto& [r2, n] : tear_positions(s, 1)) EXPECT_EQ(n, 2);
  }
}

// The tear ends where it reaches the boundary, so a crossing that would leave a sliver there goes to the
// boundary vertex instead; elsewhere on the boundary the end stays where the segment crosses it. (Without
// this, table-tear on 1 100 triangles ended on a 1.8° sliver strained to 56%.)
TEST(Remeshing, ReachingTheBoundaryBesideAVertexEndsAtThatVertex) {
  RemeshParams params;
  params.snap_fraction = 0.03;  // the tension rays' snap: crossings inside the sheet stay exact
  const Vec2 corner(0.125, 0.0);  // boundary vertex (5, 0) of the 8 x 8 grid
  for (const double offset : {0.035, 0.5}) {  // of the bottom edge's 2.5 cm, left of the corner
    Sheet s = make_grid(8, 8, 0.0, 1);
    const double area = total_rest_area(s.tris);
    const int32_t p = notch_vertex(8, 8);
    const Vec2 crossing = corner - Vec2(offset * kW / 8, 0.0);
    const Vec2 next = s.verts.rest[p] + 1.05 * (crossing - s.verts.rest[p]);  // beyond the bottom edge
    const CutResult r = cut_tear_segment(p, next, Vec2::Zero(), 0, params, s);
    ASSERT_TRUE(r.cut) << offset;
    EXPECT_TRUE(r.reached_boundary) << offset;
    expect_valid_after_cut(s, area, r, 0);
    if (offset < 0.1) {
      EXPECT_EQ(r.end, corner) << "a split 0.9 mm from the corner would leave a sliver";
    } else {
      EXPECT_NEAR((r.end - crossing).norm(), 0.0, 1e-12) << "far from a vertex the end is where it crosses";
    }
    // No triangle at the end is thinner than the cut allows.
    for (int32_t t = 0; t < s.tris.size(); ++t) {
      const Tri& q = s.tris.tri[t];
      const Vec2 a = s.verts.rest[q[0]], b = s.verts.rest[q[1]], c = s.verts.rest[q[2]];
      if ((a - r.end).norm() > 1e-12 && (b - r.end).norm() > 1e-12 && (c - r.end).norm() > 1e-12) continue;
      auto angle = [](const Vec2& o, const Vec2& u, const Vec2& w) {
        const Vec2 d1 = u - o, d2 = w - o;
        return std::atan2(std::abs(d1.x() * d2.y() - d1.y() * d2.x()), d1.dot(d2));
      };
      const double thinnest = std::min({angle(a, b, c), angle(b, c, a), angle(c, a, b)});
      EXPECT_GT(thinnest, params.min_angle_deg * std::numbers::pi / 180.0) << "offset " << offset << ", triangle " << t;
    }
  }
}

TEST(Remeshing, DirectionOutOfTheSheetChangesNothing) {
  Sheet s = make_grid(8, 8, 0.2, 4);
  const Sheet before = s;
  const int32_t p = notch_vertex(8, 8);
  const Vec2 r = s.verts.rest[p];
  const int32_t along = s.topo.boundary_next[p];
  for (const Vec2& next : {Vec2(r + Vec2(0, 0.05)), Vec2(r + Vec2(0.01, 0.05)),
                           Vec2(r + 2.0 * (s.verts.rest[along] - r)), r}) {
    const CutResult res = cut_tear_segment(p, next, Vec2::Zero(), 0, RemeshParams{}, s);
    EXPECT_FALSE(res.cut);
  }
  // From the corner (0, 0) outward, and from an interior vertex.
  EXPECT_FALSE(cut_tear_segment(0, Vec2(-0.01, -0.01), Vec2::Zero(), 0, RemeshParams{}, s).cut);
  EXPECT_FALSE(cut_tear_segment(40, Vec2(0.05, 0.05), Vec2::Zero(), 0, RemeshParams{}, s).cut);
  EXPECT_EQ(s.verts.rest, before.verts.rest);
  EXPECT_EQ(s.verts.x, before.verts.x);
  EXPECT_EQ(s.verts.v, before.verts.v);
  EXPECT_EQ(s.verts.flags, before.verts.flags);
  EXPECT_EQ(s.verts.tear, before.verts.tear);
  EXPECT_EQ(s.verts.mass, before.verts.mass);
  EXPECT_EQ(s.tris.tri, before.tris.tri);
  EXPECT_EQ(s.tris.rest_area, before.tris.rest_area);
  EXPECT_EQ(s.tris.piece, before.tris.piece);
  EXPECT_EQ(s.topology_version, before.topology_version);
}

TEST(Remeshing, FingerAndTipIdsFollowRemovedVertices) {
  Sheet s = make_grid(8, 8, 0.15, 21);
  const double area = total_rest_area(s.tris);
  const Vec2 d = Vec2(-0.05, -1).normalized();
  const int32_t p = notch_vertex(8, 8);
  const CutResult r1 = cut_tear_segment(p, s.verts.rest[p] + 0.04 * d, Vec2::Zero(), 0, RemeshParams{}, s);
  ASSERT_TRUE(r1.cut);
  // Fingers and tips on the highest ids (the ones swap-remove moves) and on ordinary vertices.
  const int32_t n = s.verts.size();
  std::vector<int32_t> held{n - 1, n - 2, n - 3, 3, 60};
  held.erase(std::remove(held.begin(), held.end(), r1.tip_vertex), held.end());
  std::vector<Vec2> held_rest;
  for (int32_t v : held) {
    Finger f;
    f.vertex = v;
    s.fingers.push_back(f);
    Tip t;
    t.vertex = v;
    s.tips.push_back(t);
    held_rest.push_back(s.verts.rest[v]);
  }
  s.tips.push_back(Tip{r1.tip_vertex, 0, d});  // the tip being continued
  const CutResult r2 = cut_tear_segment(r1.tip_vertex, r1.end + 0.04 * d, d, 0, RemeshParams{}, s);
  ASSERT_TRUE(r2.cut);
  expect_valid_after_cut(s, area, r2, 0);
  EXPECT_EQ(r2.removed_vertices, 2);
  for (size_t i = 0; i < held.size(); ++i) {
    ASSERT_GE(s.fingers[i].vertex, 0);
    ASSERT_LT(s.fingers[i].vertex, s.verts.size());
    EXPECT_EQ(s.verts.rest[s.fingers[i].vertex], held_rest[i]) << i;
    EXPECT_EQ(s.verts.rest[s.tips[i].vertex], held_rest[i]) << i;
  }
  // The continued tip's old vertex was removed: it points at a valid vertex until the caller moves it.
  EXPECT_GE(s.tips.back().vertex, 0);
  EXPECT_LT(s.tips.back().vertex, s.verts.size());
}

// A pad's vertices (systems/physics/fingers.hpp) are held like a finger's: ids that swap-remove moves follow
// with their offsets (and HeldTipIsNotRemoved: a straight continuation keeps a tip that a pad holds).
TEST(Remeshing, PadVerticesFollowRemovedVertices) {
  Sheet s = make_grid(8, 8, 0.15, 21);
  const Vec2 d = Vec2(-0.05, -1).normalized();
  const int32_t p = notch_vertex(8, 8);
  const CutResult r1 = cut_tear_segment(p, s.verts.rest[p] + 0.04 * d, Vec2::Zero(), 0, RemeshParams{}, s);
  ASSERT_TRUE(r1.cut);
  const int32_t n = s.verts.size();
  Finger f;
  f.vertex = 3;
  f.pad = {n - 1, n - 2, n - 3, 60};
  f.pad.erase(std::remove(f.pad.begin(), f.pad.end(), r1.tip_vertex), f.pad.end());
  std::vector<Vec2> pad_rest;
  for (size_t j = 0; j < f.pad.size(); ++j) {
    f.pad_offset.push_back(Vec3(double(j), 0, 0));
    pad_rest.push_back(s.verts.rest[f.pad[j]]);
  }
  s.fingers.push_back(f);
  s.tips.push_back(Tip{r1.tip_vertex, 0, d});
  const CutResult r2 = cut_tear_segment(r1.tip_vertex, r1.end + 0.04 * d, d, 0, RemeshParams{}, s);
  ASSERT_TRUE(r2.cut);
  EXPECT_EQ(r2.removed_vertices, 2);
  const Finger& g = s.fingers[0];
  ASSERT_EQ(g.pad.size(), pad_rest.size());
  for (size_t j = 0; j < g.pad.size(); ++j) {
    ASSERT_LT(g.pad[j], s.verts.size());
    EXPECT_EQ(s.verts.rest[g.pad[j]], pad_rest[j]) << j;
    EXPECT_EQ(g.pad_offset[j], Vec3(double(j), 0, 0)) << j;
  }
}

// A finger holds the tip, by its own vertex or its pad's: a straight continuation keeps it (a held vertex
// must not disappear), and the finger stays on the original id at the same place.
TEST(Remeshing, HeldTipIsNotRemoved) {
  for (const bool by_pad : {false, true}) {  // the finger's own vertex, or one of its pad's
    Sheet s = make_grid(8, 8, 0.1, 8);
    const double area = total_rest_area(s.tris);
    const Vec2 d = Vec2(0.05, -1).normalized();
    const int32_t p = notch_vertex(8, 8);
    const CutResult r1 = cut_tear_segment(p, s.verts.rest[p] + 0.03 * d, Vec2::Zero(), 0, RemeshParams{}, s);
    ASSERT_TRUE(r1.cut);
    Finger f;
    f.vertex = by_pad ? 3 : r1.tip_vertex;
    if (by_pad) f.pad = {r1.tip_vertex}, f.pad_offset = {Vec3::Zero()};
    s.fingers.push_back(f);
    const Vec2 held = s.verts.rest[r1.tip_vertex];
    const CutResult r2 = cut_tear_segment(r1.tip_vertex, r1.end + 0.03 * d, d, 0, RemeshParams{}, s);
    ASSERT_TRUE(r2.cut);
    expect_valid_after_cut(s, area, r2, 0);
    EXPECT_EQ(r2.removed_vertices, 0) << by_pad;
    const int32_t now = by_pad ? s.fingers[0].pad[0] : s.fingers[0].vertex;
    EXPECT_EQ(now, r1.tip_vertex) << by_pad;
    EXPECT_EQ(s.verts.rest[now], held) << by_pad;
    EXPECT_EQ(count_at(s, held), 2) << by_pad;
  }
}

TEST(Remeshing, RandomTearSequencesKeepInvariants) {
  int cuts = 0, boundary_hits = 0, stuck = 0, removals = 0, kept_straight = 0;
  double worst_miss = 0;
  for (int seq = 0; seq < 200; ++seq) {
    std::mt19937_64 rng(1000 + seq);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    const int nx = 6 + seq % 7, ny = 6 + (seq / 7) % 7;
    Sheet s = make_grid(nx, ny, 0.25 * uni(rng), 77 + seq);
    ASSERT_EQ(check_mesh_invariants(s), "");
    const double area = total_rest_area(s.tris);
    const double cell = std::min(kW / nx, kH / ny);
    int32_t tip = notch_vertex(nx, ny);
    Vec2 prev = Vec2::Zero();
    Vec2 dir(0, -1);
    for (int k = 0; k < 10; ++k) {
      CutResult r;
      Vec2 d, target;
      for (int attempt = 0; attempt < 8 && !r.cut; ++attempt) {
        const double turn = (uni(rng) * 2 - 1) * std::numbers::pi / 3;
        // Straight continuations are frequent in practice: exercise the removal of p.
        d = uni(rng) < 0.3 ? dir : Vec2(Eigen::Rotation2Dd(turn) * dir);
        const double len = cell * (0.05 + 1.5 * uni(rng));
        target = s.verts.rest[tip] + len * d;
        r = cut_tear_segment(tip, target, prev, seq, RemeshParams{}, s);
        if (!r.cut) {
          ASSERT_EQ(check_mesh_invariants(s, area), "");
        }
      }
      if (!r.cut) {
        ++stuck;
        break;
      }
      ++cuts;
      removals += r.removed_vertices > 0;
      const double turn_angle = std::acos(std::clamp(prev.dot(d), -1.0, 1.0));
      kept_straight += prev.squaredNorm() > 0 && turn_angle <= 0.1 && r.removed_vertices == 0;
      // The tip is where it was asked, up to a snap (a quarter of a local edge, at most a cell diagonal).
      if (!r.reached_boundary) {
        const double miss = (r.end - target).norm() / std::max(kW / nx, kH / ny);
        EXPECT_LE(miss, 0.25 * 1.5 * std::sqrt(2.0)) << seq << " " << k;
        worst_miss = std::max(worst_miss, miss);
      }
      expect_valid_after_cut(s, area, r, seq);
      if (::testing::Test::HasFatalFailure()) {
        ADD_FAILURE() << "sequence " << seq << " cut " << k;
        return;
      }
      if (r.reached_boundary) {
        ++boundary_hits;
        EXPECT_GE(s.topo.piece_count, 1);
        break;
      }
      tip = r.tip_vertex;
      prev = d;
      dir = d;
    }
  }
  std::printf("cuts %d, reached boundary %d, p removed %d, straight but kept %d, no cut after 8 directions %d, "
              "worst tip miss %.3f cells\n", cuts, boundary_hits, removals, kept_straight, stuck, worst_miss);
  EXPECT_GT(cuts, 1000);
  EXPECT_GT(removals, 100);
  EXPECT_GT(boundary_hits, 0);
}

// Many tears on one sheet from random boundary vertices (outline, lips, kept corners, tips): segments
// cross earlier lips (the sheet falls apart into pieces), start at the corners of the rectangle, run along
// grid lines. A refused cut must leave the sheet unchanged.
TEST(Remeshing, RandomTearsFromAnyBoundaryVertex) {
  int cuts = 0, refused = 0, max_pieces = 0;
  double worst_angle = std::numbers::pi;
  for (int sheet_index = 0; sheet_index < 60; ++sheet_index) {
    std::mt19937_64 rng(5000 + sheet_index);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    const int nx = 5 + sheet_index % 6, ny = 5 + (sheet_index / 6) % 6;
    Sheet s = make_grid(nx, ny, 0.25 * uni(rng), 300 + sheet_index);
    const double area = total_rest_area(s.tris);
    const double cell = std::min(kW / nx, kH / ny);
    for (int k = 0; k < 15; ++k) {
      const int32_t p = random_boundary_vertex(s, uni(rng));
      // Mostly towards the inside (the interior bisector at p), sometimes anywhere.
      const Vec2 rp = s.verts.rest[p];
      const Vec2 tn = boundary_tangent(s, p);
      const double angle = interior_pattern_angle(s.topo, s.verts.rest, p);
      const double rot = uni(rng) < 0.8 ? angle * (0.1 + 0.8 * uni(rng)) : 2 * std::numbers::pi * uni(rng);
      const Vec2 d = Eigen::Rotation2Dd(rot) * tn;
      const Vec2 prev = uni(rng) < 0.5 ? Vec2::Zero() : Vec2(Eigen::Rotation2Dd(0.2 * (uni(rng) - 0.5)) * d);
      const double len = cell * (0.02 + 3 * uni(rng));
      const Sheet before = s;
      const CutResult r = cut_tear_segment(p, rp + len * d, prev, k, RemeshParams{}, s);
      if (!r.cut) {
        ++refused;
        ASSERT_EQ(s.tris.tri, before.tris.tri);
        ASSERT_EQ(s.verts.rest, before.verts.rest);
        continue;
      }
      ++cuts;
      expect_valid_after_cut(s, area, r, k);
      if (::testing::Test::HasFatalFailure()) {
        ADD_FAILURE() << "sheet " << sheet_index << " cut " << k << " p " << p << " flags " << int(before.verts.flags[p])
                      << " reached " << r.reached_boundary << " removed " << r.removed_vertices << " new "
                      << r.new_vertices << " n " << before.verts.size() << " pieces " << before.topo.piece_count
                      << " next " << (rp + len * d).transpose() << " rp " << rp.transpose() << " end " << r.end.transpose();
        return;
      }
      max_pieces = std::max(max_pieces, s.topo.piece_count);
    }
    for (const Tri& t : s.tris.tri) {
      const Vec2 &a = s.verts.rest[t[0]], &b = s.verts.rest[t[1]], &c = s.verts.rest[t[2]];
      auto ang = [](const Vec2& p, const Vec2& q, const Vec2& w) {
        const Vec2 u = q - p, v = w - p;
        return std::atan2(std::abs(u.x() * v.y() - u.y() * v.x()), u.dot(v));
      };
      worst_angle = std::min({worst_angle, ang(a, b, c), ang(b, c, a), ang(c, a, b)});
    }
  }
  std::printf("cuts %d, refused %d, max pieces %d, smallest angle %.3f deg\n", cuts, refused, max_pieces,
              worst_angle * 180 / std::numbers::pi);
  EXPECT_GT(cuts, 500);
  EXPECT_GT(max_pieces, 2);
}

// The local refresh's own bookkeeping (Topology::fans, hinges, edge_hinge): fans that outgrow their room
// move to the end of the pool, which can be compacted; hinges a cut removes free their slots, which new
// hinges take or the last hinges fill. Long random tear sequences on one sheet must go through all of these,
// with the topology equal to a full rebuild after every cut (check_mesh_invariants).
TEST(Remeshing, LocalRefreshMovesFansCompactsThePoolAndReusesHingeSlots) {
  int cuts = 0, moved_fans = 0, compactions = 0, hinge_drops = 0;
  for (int sheet_index = 0; sheet_index < 6; ++sheet_index) {
    std::mt19937_64 rng(9000 + sheet_index);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    Sheet s = make_grid(8, 8, 0.2, 400 + sheet_index);
    const double area = total_rest_area(s.tris);
    const double cell = std::min(kW / 8, kH / 8);
    for (int k = 0; k < 150; ++k) {
      const int32_t p = random_boundary_vertex(s, uni(rng));
      const Vec2 rp = s.verts.rest[p];
      const Vec2 tn = boundary_tangent(s, p);
      const double angle = interior_pattern_angle(s.topo, s.verts.rest, p);
      const Vec2 d = Eigen::Rotation2Dd(angle * (0.1 + 0.8 * uni(rng))) * tn;
      const size_t pool_before = s.topo.vt_tri.size(), hinges_before = s.topo.hinges.size();
      const int32_t unused_before = s.topo.vt_unused;
      const Vec2 next = rp + cell * (0.2 + 0.8 * uni(rng)) * d;
      const CutResult r = cut_tear_segment(p, next, Vec2::Zero(), k, RemeshParams{}, s);
      if (!r.cut) continue;
      ++cuts;
      ASSERT_EQ(check_mesh_invariants(s, area), "") << "sheet " << sheet_index << " cut " << k;
      compactions += s.topo.vt_unused < unused_before && s.topo.vt_tri.size() < pool_before;
      moved_fans += s.topo.vt_unused > unused_before;
      hinge_drops += s.topo.hinges.size() < hinges_before;
    }
    // Cuts rarely move fans (a fan outgrows its kFanSlack spare entries), so the pool seldom reaches the
    // automatic compaction: compact it here and check that only the unused entries went.
    const size_t pool = s.topo.vt_tri.size();
    const int32_t unused = s.topo.vt_unused;
    compact_fans(s.topo);
    EXPECT_EQ(s.topo.vt_unused, 0);
    EXPECT_EQ(s.topo.vt_tri.size(), pool - unused);
    ASSERT_EQ(check_mesh_invariants(s, area), "");
    compactions += unused > 0;
  }
  std::printf("cuts %d, cuts that moved a fan %d, compactions %d, cuts that removed hinges %d\n", cuts, moved_fans,
              compactions, hinge_drops);
  EXPECT_GT(cuts, 300);
  EXPECT_GT(moved_fans, 0);
  EXPECT_GT(compactions, 0);
  EXPECT_GT(hinge_drops, 0);
}
