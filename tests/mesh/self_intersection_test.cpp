// The exact self-intersection count (systems/mesh/self_intersection.hpp): a flat or gently bent sheet has
// none; a needle through one triangle is one pair; a triangle whose corner lies exactly on the sheet
// touches (counts), one 1e-18 m above it does not; adjacent triangles and a tear's coincident duplicate
// vertex are excluded.
#include "systems/mesh/self_intersection.hpp"
#include "tests/test_meshes.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace pt;

namespace {
// Appends a triangle of three new vertices.
void add_triangle(Sheet& s, std::vector<Tri>& tris, const Vec3& a, const Vec3& b, const Vec3& c) {
  const int32_t n = static_cast<int32_t>(s.verts.x.size());
  s.verts.x.push_back(a);
  s.verts.x.push_back(b);
  s.verts.x.push_back(c);
  tris.push_back({n, n + 1, n + 2});
}
}  // namespace

TEST(SelfIntersection, AFlatOrBentSheetHasNone) {
  Sheet s = test::grid_sheet(0.1, 0.1, 10, 10, 0.2, 4);
  EXPECT_EQ(count_self_intersections(s.verts.x, s.tris.tri).intersecting, 0);
  for (Vec3& x : s.verts.x) x.z() = 0.05 * std::sin(20 * x.x());
  const SelfIntersectionCount c = count_self_intersections(s.verts.x, s.tris.tri);
  EXPECT_EQ(c.intersecting, 0);
  EXPECT_GT(c.candidates, 0) << "the broad phase found neighbours-of-neighbours to test";
}

TEST(SelfIntersection, ANeedleThroughOneTriangleIsOnePair) {
  Sheet s = test::grid_sheet(0.1, 0.1, 10, 10, 0, 1);
  std::vector<Tri> tris = s.tris.tri;
  // Cell (1, 1) spans [0.01, 0.02]²; its diagonal runs from (0.01, 0.01) to (0.02, 0.02): the needle's
  // foot (0.0170, 0.0120)–(0.0172, 0.0120) lies inside the triangle below that diagonal.
  add_triangle(s, tris, Vec3(0.0170, 0.012, -0.01), Vec3(0.0172, 0.012, -0.01), Vec3(0.0170, 0.012, 0.01));
  EXPECT_EQ(count_self_intersections(s.verts.x, tris).intersecting, 1);
}

TEST(SelfIntersection, TouchingIsExactAndCounts) {
  Sheet s = test::grid_sheet(0.1, 0.1, 10, 10, 0, 1);
  std::vector<Tri> on = s.tris.tri, above = s.tris.tri;
  add_triangle(s, on, Vec3(0.0171, 0.012, 0), Vec3(0.0172, 0.013, 0.01), Vec3(0.0173, 0.012, 0.01));
  EXPECT_EQ(count_self_intersections(s.verts.x, on).intersecting, 1) << "a corner exactly on the sheet";
  s.verts.x.resize(s.verts.x.size() - 3);
  add_triangle(s, above, Vec3(0.0171, 0.012, 1e-18), Vec3(0.0172, 0.013, 0.01), Vec3(0.0173, 0.012, 0.01));
  EXPECT_EQ(count_self_intersections(s.verts.x, above).intersecting, 0) << "1e-18 m above it";
}

TEST(SelfIntersection, AdjacentTrianglesAndCoincidentDuplicatesAreExcluded) {
  Sheet s = test::grid_sheet(0.1, 0.1, 4, 4, 0, 1);
  std::vector<Tri> tris = s.tris.tri;
  // A triangle folded back onto its neighbour through their shared vertex 0 only: adjacent, not counted.
  add_triangle(s, tris, s.verts.x[0], Vec3(0.02, 0.005, 0), Vec3(0.005, 0.02, 0));
  EXPECT_EQ(count_self_intersections(s.verts.x, tris).intersecting, 0) << "one corner duplicates vertex 0's point";
  // The same triangle lying in the sheet from a point that is no corner of it: it overlaps, counted.
  s.verts.x[s.verts.x.size() - 3] = Vec3(0.001, 0.001, 0);
  EXPECT_GT(count_self_intersections(s.verts.x, tris).intersecting, 0);
}
