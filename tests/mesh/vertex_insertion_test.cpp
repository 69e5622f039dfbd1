// Inserting a vertex where a finger is put: the mesh stays valid, the area and the deformed surface are
// unchanged (the new vertex lies on the surface), close points snap to existing vertices.
#include "systems/mesh/vertex_insertion.hpp"
#include "tests/test_meshes.hpp"

#include <gtest/gtest.h>

using namespace pt;

TEST(VertexInsertion, InsideEdgeBoundaryAndSnap) {
  Sheet s = test::grid_sheet(0.1, 0.1, 5, 5, 0.2, 3);
  // Bend it so barycentric placement is visible.
  for (int i = 0; i < s.verts.size(); ++i) s.verts.x[i].z() = 0.3 * s.verts.rest[i].x() * s.verts.rest[i].x();
  const double area = total_rest_area(s.tris);
  const int32_t nv = s.verts.size();

  const int32_t a = insert_pattern_vertex(Vec2(0.031, 0.047), {}, s);  // inside
  EXPECT_EQ(a, nv);
  EXPECT_EQ(check_mesh_invariants(s, area), "");
  const int32_t b = insert_pattern_vertex(Vec2(0.05, 0.0), {}, s);  // on the boundary edge
  EXPECT_EQ(check_mesh_invariants(s, area), "");
  EXPECT_TRUE(s.verts.flags[b] & kBoundary);
  EXPECT_NEAR(s.verts.rest[b].y(), 0.0, 1e-15);
  const int32_t c = insert_pattern_vertex(Vec2(0.1, 0.1) - Vec2(1e-5, 1e-5), {}, s);  // snaps to the corner
  EXPECT_EQ(s.verts.rest[c], Vec2(0.1, 0.1));
  EXPECT_EQ(insert_pattern_vertex(Vec2(0.2, 0.2), {}, s), -1);  // outside
  // New vertices lie on the (piecewise linear) deformed surface: z within the chord error of x².
  EXPECT_NEAR(s.verts.x[a].z(), 0.3 * 0.031 * 0.031, 0.3 * 0.02 * 0.02);
}
