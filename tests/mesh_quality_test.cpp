// Lawson flips near new vertices: fewer slivers, same area, valid mesh, boundary edges untouched.
#include "systems/mesh_quality.hpp"
#include "systems/topology.hpp"
#include "test_meshes.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

using namespace pt;

namespace {
double min_angle(const Sheet& s) {
  double m = std::numbers::pi;
  for (const Tri& t : s.tris.tri)
    for (int i = 0; i < 3; ++i) {
      const Vec2 a = s.verts.rest[t[i]], b = s.verts.rest[t[(i + 1) % 3]], c = s.verts.rest[t[(i + 2) % 3]];
      m = std::min(m, std::acos(std::clamp((b - a).normalized().dot((c - a).normalized()), -1.0, 1.0)));
    }
  return m;
}
}  // namespace

TEST(MeshQuality, FlipsRemoveAFanOfSlivers) {
  Sheet s = test::grid_sheet(0.1, 0.1, 4, 4);
  // Insert a point very close to an edge of a triangle (1 → 3 split): two slivers.
  const int32_t nv = s.verts.size();
  s.verts.resize(nv + 1);
  const Tri t0 = s.tris.tri[5];
  const Vec2 p = 0.5 * (s.verts.rest[t0[0]] + s.verts.rest[t0[1]]) * 0.98 + 0.02 * s.verts.rest[t0[2]];
  s.verts.rest[nv] = p;
  s.verts.x[nv] = Vec3(p.x(), p.y(), 0);
  s.verts.flags[nv] = kNew;
  s.tris.tri[5] = {t0[0], t0[1], nv};
  s.tris.tri.push_back({t0[1], t0[2], nv});
  s.tris.tri.push_back({t0[2], t0[0], nv});
  s.tris.resize(static_cast<int32_t>(s.tris.tri.size()));
  refresh_after_topology_change(s);
  const double area = total_rest_area(s.tris);
  const double before = min_angle(s);
  const int32_t flips = flip_towards_delaunay_near_new_vertices(FlipParams{}, s);
  EXPECT_GT(flips, 0);
  EXPECT_EQ(check_mesh_invariants(s, area), "");
  EXPECT_GT(min_angle(s), 2 * before);
  // Boundary edges were never flipped: every boundary vertex still lies on the square's outline.
  for (int32_t v = 0; v < s.verts.size(); ++v) {
    if (s.topo.boundary_next[v] < 0) continue;
    const Vec2 r = s.verts.rest[v];
    const double to_outline = std::min({r.x(), 0.1 - r.x(), r.y(), 0.1 - r.y()});
    EXPECT_LT(std::abs(to_outline), 1e-12) << v;
  }
}

TEST(MeshQuality, NothingNewNothingFlipped) {
  Sheet s = test::grid_sheet(0.1, 0.1, 4, 4, 0.3, 5);
  const auto before = s.tris.tri;
  EXPECT_EQ(flip_towards_delaunay_near_new_vertices(FlipParams{}, s), 0);
  EXPECT_EQ(s.tris.tri, before);
}
