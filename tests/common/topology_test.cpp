// Topology: fans, neighbours, boundary loops, pieces, inward angles and the invariant checker, on
// hand-built meshes whose answers are known.
#include "systems/common/topology.hpp"

#include <gtest/gtest.h>

#include <numbers>

using namespace pt;

namespace {
// Unit square split into two triangles, plus an L-shape of three squares for an inward angle.
Sheet square_sheet() {
  Sheet s;
  s.verts.resize(4);
  s.verts.rest = {Vec2(0, 0), Vec2(1, 0), Vec2(1, 1), Vec2(0, 1)};
  for (int i = 0; i < 4; ++i) s.verts.x[i] = Vec3(s.verts.rest[i].x(), s.verts.rest[i].y(), 0);
  s.tris.resize(2);
  s.tris.tri = {Tri{0, 1, 2}, Tri{0, 2, 3}};
  refresh_after_topology_change(s);
  return s;
}
Sheet l_shape_sheet() {
  // (0,0)-(2,0)-(2,1)-(1,1)-(1,2)-(0,2); vertex 3 at (1,1) is the inward corner.
  Sheet s;
  s.verts.resize(8);
  s.verts.rest = {Vec2(0, 0), Vec2(1, 0), Vec2(2, 0), Vec2(2, 1), Vec2(1, 1), Vec2(0, 1), Vec2(0, 2), Vec2(1, 2)};
  s.tris.resize(6);
  s.tris.tri = {Tri{0, 1, 4}, Tri{0, 4, 5}, Tri{1, 2, 3}, Tri{1, 3, 4}, Tri{5, 4, 7}, Tri{5, 7, 6}};
  refresh_after_topology_change(s);
  return s;
}
}  // namespace

TEST(Topology, SquareNeighboursAndBoundary) {
  Sheet s = square_sheet();
  EXPECT_EQ(check_mesh_invariants(s, 1.0), "");
  EXPECT_EQ(s.topo.hinges.size(), 1u);
  EXPECT_EQ(s.topo.piece_count, 1);
  EXPECT_EQ(s.topo.neighbor[0][2], 1);  // edge (2,0) of triangle 0 is shared with triangle 1
  for (int v = 0; v < 4; ++v) EXPECT_TRUE(s.verts.flags[v] & kBoundary);
  EXPECT_EQ(s.topo.boundary_next[0], 1);
  EXPECT_EQ(s.topo.boundary_next[1], 2);
  EXPECT_EQ(s.topo.boundary_prev[0], 3);
  EXPECT_NEAR(interior_pattern_angle(s.topo, s.verts.rest, 0), std::numbers::pi / 2, 1e-12);
  EXPECT_NEAR(s.verts.mass[0] + s.verts.mass[1] + s.verts.mass[2] + s.verts.mass[3],
              s.material.density * s.material.thickness * 1.0, 1e-15);
}

TEST(Topology, InwardAngleOfAnLShape) {
  Sheet s = l_shape_sheet();
  EXPECT_EQ(check_mesh_invariants(s, 3.0), "");
  EXPECT_NEAR(interior_pattern_angle(s.topo, s.verts.rest, 4), 1.5 * std::numbers::pi, 1e-12);
  for (int v = 0; v < 8; ++v) EXPECT_EQ(bool(s.verts.flags[v] & kInward), v == 4) << v;
  // Straight boundary vertices (angle π) are not inward.
  EXPECT_NEAR(interior_pattern_angle(s.topo, s.verts.rest, 1), std::numbers::pi, 1e-12);
}

TEST(Topology, InvariantCheckerCatchesViolations) {
  Sheet s = square_sheet();
  Sheet flipped = s;
  std::swap(flipped.tris.tri[0][1], flipped.tris.tri[0][2]);
  EXPECT_NE(check_mesh_invariants(flipped), "");
  EXPECT_NE(check_mesh_invariants(s, 2.0), "");  // wrong area
  // Bow-tie: two triangles sharing only vertex 0.
  Sheet bow;
  bow.verts.resize(5);
  bow.verts.rest = {Vec2(0, 0), Vec2(1, 0), Vec2(1, 1), Vec2(-1, 0), Vec2(-1, -1)};
  bow.tris.resize(2);
  bow.tris.tri = {Tri{0, 1, 2}, Tri{0, 3, 4}};
  refresh_after_topology_change(bow);
  EXPECT_NE(check_mesh_invariants(bow).find("bow-tie"), std::string::npos);
}

TEST(Topology, PiecesAreCounted) {
  Sheet s;
  s.verts.resize(6);
  s.verts.rest = {Vec2(0, 0), Vec2(1, 0), Vec2(0, 1), Vec2(5, 0), Vec2(6, 0), Vec2(5, 1)};
  s.tris.resize(2);
  s.tris.tri = {Tri{0, 1, 2}, Tri{3, 4, 5}};
  refresh_after_topology_change(s);
  EXPECT_EQ(s.topo.piece_count, 2);
  EXPECT_EQ(s.tris.piece[0], 0);
  EXPECT_EQ(s.tris.piece[1], 1);
}
