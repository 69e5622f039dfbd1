// Segment tests and shortest paths inside a torn pattern (systems/tearing/pattern_paths.hpp), on grids
// with slits cut from the bottom edge: the lips coincide in position but are different vertices.
#include "systems/tearing/pattern_paths.hpp"
#include "systems/common/topology.hpp"

#include "tests/test_meshes.hpp"

#include <gtest/gtest.h>

#include <numbers>

using namespace pt;
using test::Slit;
using test::slit_grid;
using test::vertex_at;

namespace {

constexpr double kW = 0.2, kH = 0.15;

// 20 x 15 cells of 1 cm; a slit along x = 0.1 from the bottom edge up to its tip (0.1, 0.06).
Sheet one_slit() { return slit_grid(kW, kH, 20, 15, {Slit{10, 6}}); }

struct Query {
  PatternBoundary boundary;
  SegmentQueryScratch scratch;
  const Sheet* s = nullptr;
  explicit Query(const Sheet& sheet, int32_t piece = 0) : s(&sheet) {
    build_pattern_boundary(sheet.topo, sheet.verts.rest, sheet.tris.piece, piece, PatternPathParams{}, boundary);
  }
  bool inside(const Vec2& a, int32_t av, const Vec2& b, int32_t bv) {
    return segment_in_pattern(boundary, s->topo, s->verts.rest, a, av, b, bv, scratch);
  }
  bool inside(int32_t av, int32_t bv) { return inside(s->verts.rest[av], av, s->verts.rest[bv], bv); }
};

}  // namespace

TEST(PatternPaths, BoundaryOfAPieceAndItsReflexVertices) {
  const Sheet s = one_slit();
  ASSERT_EQ(check_mesh_invariants(s), "");
  ASSERT_EQ(s.topo.piece_count, 1);
  Query q(s);
  // Outline 2·(20 + 15) edges, plus 6 edges on each lip.
  EXPECT_EQ(q.boundary.edges.size(), 70u + 12u);
  // The only reflex vertex is the tip (2π); the lips are straight (π) and the corners convex.
  const int32_t tip = vertex_at(s, Vec2(0.1, 0.06));
  ASSERT_EQ(q.boundary.reflex.size(), 1u);
  EXPECT_EQ(q.boundary.reflex[0], tip);
  EXPECT_NEAR(interior_pattern_angle(s.topo, s.verts.rest, tip), 2 * std::numbers::pi, 1e-12);
}

TEST(PatternPaths, SegmentsAcrossAlongAndAroundASlit) {
  const Sheet s = one_slit();
  Query q(s);
  const int32_t tip = vertex_at(s, Vec2(0.1, 0.06));
  // Across the slit between interior points: blocked, also when it passes exactly through the lip
  // vertices at (0.1, 0.03) (no edge is crossed at an interior point there, the lips' vertices decide).
  EXPECT_FALSE(q.inside(Vec2(0.05, 0.02), -1, Vec2(0.15, 0.035), -1));
  EXPECT_FALSE(q.inside(Vec2(0.05, 0.03), -1, Vec2(0.15, 0.03), -1));
  EXPECT_FALSE(q.inside(Vec2(0.05, 0.0), -1, Vec2(0.15, 0.06), -1));  // through (0.1, 0.03) diagonally
  // Above the tip: free; exactly through the tip: it grazes the slit's end, allowed.
  EXPECT_TRUE(q.inside(Vec2(0.05, 0.07), -1, Vec2(0.15, 0.065), -1));
  EXPECT_TRUE(q.inside(Vec2(0.05, 0.06), -1, Vec2(0.15, 0.06), -1));
  EXPECT_TRUE(q.inside(Vec2(0.05, 0.02), -1, Vec2(0.15, 0.10), -1));  // through the tip, diagonally
  // From the tip into the material on either side, and back along the slit between the lips.
  const int32_t left_foot = vertex_at(s, Vec2(0.1, 0.0), Vec2(-1, 1));
  const int32_t right_foot = vertex_at(s, Vec2(0.1, 0.0), Vec2(1, 1));
  ASSERT_NE(left_foot, right_foot);
  EXPECT_TRUE(q.inside(s.verts.rest[tip], tip, Vec2(0.05, 0.01), -1));
  EXPECT_TRUE(q.inside(s.verts.rest[tip], tip, Vec2(0.15, 0.01), -1));
  EXPECT_TRUE(q.inside(tip, left_foot));
  EXPECT_TRUE(q.inside(tip, right_foot));
  // The two copies of a lip vertex are not joined (zero length), and a lip vertex does not see the far
  // side through the slit.
  const int32_t left_lip = vertex_at(s, Vec2(0.1, 0.03), Vec2(-1, 0));
  const int32_t right_lip = vertex_at(s, Vec2(0.1, 0.03), Vec2(1, 0));
  ASSERT_NE(left_lip, right_lip);
  EXPECT_FALSE(q.inside(left_lip, right_lip));
  EXPECT_FALSE(q.inside(s.verts.rest[left_lip], left_lip, Vec2(0.15, 0.03), -1));
  EXPECT_TRUE(q.inside(s.verts.rest[right_lip], right_lip, Vec2(0.15, 0.03), -1));
  // Along the outline and out of it.
  const int32_t a = vertex_at(s, Vec2(0.0, 0.0)), b = vertex_at(s, Vec2(0.05, 0.0));
  EXPECT_TRUE(q.inside(a, b));
  EXPECT_FALSE(q.inside(s.verts.rest[b], b, Vec2(0.05, -0.01), -1));
}

TEST(PatternPaths, ShortestPathBendsAtTheTip) {
  const Sheet s = one_slit();
  Query q(s);
  const int32_t tip = vertex_at(s, Vec2(0.1, 0.06));
  const int32_t p = vertex_at(s, Vec2(0.05, 0.0));
  const int32_t left = vertex_at(s, Vec2(0.03, 0.04));
  const int32_t right = vertex_at(s, Vec2(0.16, 0.02));
  const int32_t right_lip = vertex_at(s, Vec2(0.1, 0.03), Vec2(1, 0));
  const std::vector<int32_t> targets{left, right, right_lip, p};
  PatternPathScratch scratch;
  PatternPaths paths;
  shortest_pattern_paths(q.boundary, s.topo, s.verts.rest, p, targets, scratch, paths);
  ASSERT_EQ(paths.paths.size(), 4u);
  const Vec2 P = s.verts.rest[p], T = s.verts.rest[tip];
  EXPECT_TRUE(paths.paths[0].straight);
  EXPECT_NEAR((paths.paths[0].first_direction - (Vec2(0.03, 0.04) - P).normalized()).norm(), 0, 1e-15);
  // Around the tip: P → T → target.
  for (int k : {1, 2}) {
    const PatternPath& path = paths.paths[k];
    EXPECT_TRUE(path.reachable);
    EXPECT_FALSE(path.straight);
    EXPECT_EQ(path.first_corner, tip);
    EXPECT_NEAR((path.first_direction - (T - P).normalized()).norm(), 0, 1e-15);
    EXPECT_EQ(path.point_end - path.point_begin, 2);
    EXPECT_NEAR(path.length, (T - P).norm() + (paths.points[path.point_end - 1] - T).norm(), 1e-15);
  }
  EXPECT_NEAR(paths.paths[2].length, (T - P).norm() + 0.03, 1e-15);
  EXPECT_FALSE(paths.paths[3].reachable);  // the source itself

  // From one copy of a lip vertex to the other: up one lip, round the tip, down the other.
  const int32_t left_lip = vertex_at(s, Vec2(0.1, 0.03), Vec2(-1, 0));
  const std::vector<int32_t> other{right_lip};
  shortest_pattern_paths(q.boundary, s.topo, s.verts.rest, left_lip, other, scratch, paths);
  ASSERT_TRUE(paths.paths[0].reachable);
  EXPECT_EQ(paths.paths[0].first_corner, tip);
  EXPECT_NEAR(paths.paths[0].length, 0.06, 1e-15);
  EXPECT_NEAR((paths.paths[0].first_direction - Vec2(0, 1)).norm(), 0, 1e-15);
}

TEST(PatternPaths, TwoSlitsNeedTwoCorners) {
  // Slits at x = 0.06 (tip 0.06, 0.05) and x = 0.12 (tip 0.12, 0.08). From the bottom left corner of the
  // first slit's left to the far right bottom: over both tips.
  const Sheet s = slit_grid(kW, kH, 20, 15, {Slit{6, 5}, Slit{12, 8}});
  ASSERT_EQ(check_mesh_invariants(s), "");
  Query q(s);
  const int32_t t1 = vertex_at(s, Vec2(0.06, 0.05)), t2 = vertex_at(s, Vec2(0.12, 0.08));
  const int32_t from = vertex_at(s, Vec2(0.02, 0.0)), to = vertex_at(s, Vec2(0.18, 0.0));
  PatternPathScratch scratch;
  PatternPaths paths;
  const std::vector<int32_t> targets{to};
  shortest_pattern_paths(q.boundary, s.topo, s.verts.rest, from, targets, scratch, paths);
  ASSERT_TRUE(paths.paths[0].reachable);
  const Vec2 A = s.verts.rest[from], T1 = s.verts.rest[t1], T2 = s.verts.rest[t2], B = s.verts.rest[to];
  // The segment A → T2 meets x = 0.06 at y = 0.032, below the first tip: the taut path bends at T1 first.
  EXPECT_EQ(paths.paths[0].first_corner, t1);
  EXPECT_NEAR(paths.paths[0].length, (T1 - A).norm() + (T2 - T1).norm() + (B - T2).norm(), 1e-15);
  EXPECT_EQ(paths.points.size(), 3u);
  EXPECT_EQ(paths.point_vertex[1], t2);
}
