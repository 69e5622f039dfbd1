// The relaxation of a patch around a cut (systems/physics/local_relaxation.hpp), against the full implicit substep
// it stands for: with a radius that covers the sheet it is that substep; with a small one, every vertex
// outside the patch stays bit for bit where it was; and after a cut into a sheet stretched across it, the
// lips open, more as the patch grows, until they open as in the full substep.
#include "systems/physics/local_relaxation.hpp"
#include "systems/mesh/remeshing.hpp"
#include "tests/test_meshes.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace pt;

namespace {

// The left and right edges of a 0.2 x 0.2 m grid, pulled apart in plane by `stretch` (a strain).
void pulled_edges(const Sheet& s, double stretch, std::vector<int32_t>& held, std::vector<Vec3>& target) {
  held.clear();
  target.clear();
  for (int32_t i = 0; i < s.verts.size(); ++i) {
    const Vec2 r = s.verts.rest[i];
    if (r.x() < 1e-12 || r.x() > 0.2 - 1e-12) {
      held.push_back(i);
      target.push_back(Vec3((r.x() - 0.1) * (1 + stretch) + 0.1, r.y(), 0));
    }
  }
}

// The sheet held by its left and right edges, pulled apart by `stretch`, after `substeps` substeps.
Sheet held_sheet(const ImplicitParams& p, double stretch, int substeps, std::vector<int32_t>& held,
                 std::vector<Vec3>& target) {
  Sheet s = test::grid_sheet(0.2, 0.2, 12, 12, 0.2, 4);
  pulled_edges(s, stretch, held, target);
  ImplicitSolverPtr solver;
  for (int step = 0; step < substeps; ++step) EXPECT_TRUE(implicit_substep(p, held, target, solver, s));
  return s;
}

// The sheet hanging from its two top corners, `substeps` substeps after it was let go flat: swinging down.
Sheet hanging_sheet(const ImplicitParams& p, int substeps, std::vector<int32_t>& held, std::vector<Vec3>& target) {
  Sheet s = test::grid_sheet(0.2, 0.2, 12, 12, 0.2, 4);
  test::held_top_corners(s, 0.2, 0.2, held, target);
  ImplicitSolverPtr solver;
  for (int step = 0; step < substeps; ++step) EXPECT_TRUE(implicit_substep(p, held, target, solver, s));
  return s;
}

// The boundary vertex nearest to `at` (pattern).
int32_t nearest_boundary_vertex(const Sheet& s, const Vec2& at) {
  int32_t best = -1;
  for (int32_t v : s.topo.boundary_vertices)
    if (best < 0 || (s.verts.rest[v] - at).norm() < (s.verts.rest[best] - at).norm()) best = v;
  return best;
}

// Largest 3D distance between two vertices at the same pattern position (the lips' copies of a cut vertex).
double largest_lip_opening(const Sheet& s) {
  double widest = 0;
  for (int32_t a = 0; a < s.verts.size(); ++a)
    for (int32_t b = a + 1; b < s.verts.size(); ++b)
      if ((s.verts.rest[a] - s.verts.rest[b]).norm() < 1e-12)
        widest = std::max(widest, (s.verts.x[a] - s.verts.x[b]).norm());
  return widest;
}

}  // namespace

TEST(LocalRelaxation, PatchCoveringTheSheetIsTheFullSubstep) {
  ImplicitParams p;
  p.gravity = Vec3(0, 0, -9.81);
  std::vector<int32_t> held;
  std::vector<Vec3> target;
  const Sheet start = hanging_sheet(p, 20, held, target);
  Sheet full = start, local = start;
  const std::vector<Vec2> path = {Vec2(0.1, 0), Vec2(0.1, 0.05)};
  ImplicitSolverPtr solver;
  ASSERT_TRUE(implicit_substep(p, held, target, solver, full));
  LocalRelaxationScratch scratch;
  const LocalRelaxationResult r =
      relax_patch_after_cut(p, LocalRelaxationParams{10.0}, path, held, target, scratch, local);
  ASSERT_TRUE(r.relaxed);
  EXPECT_EQ(r.triangles, start.tris.size());
  EXPECT_EQ(r.free_vertices, start.verts.size());
  double moved = 0;
  for (int32_t i = 0; i < start.verts.size(); ++i) {
    moved = std::max(moved, (full.verts.x[i] - start.verts.x[i]).norm());
    EXPECT_LT((local.verts.x[i] - full.verts.x[i]).norm(), 1e-12) << "vertex " << i;
    EXPECT_LT((local.verts.v[i] - full.verts.v[i]).norm(), 1e-10) << "vertex " << i;
  }
  EXPECT_GT(moved, 1e-5) << "the step moved the sheet";
}

TEST(LocalRelaxation, VerticesOutsideThePatchStayWhereTheyWere) {
  ImplicitParams p;
  std::vector<int32_t> held;
  std::vector<Vec3> target;
  const Sheet start = hanging_sheet(p, 20, held, target);
  Sheet local = start;
  LocalRelaxationScratch scratch;
  const Vec2 from(0.1, 0.08), to(0.1, 0.12);
  const std::vector<Vec2> path = {from, to};
  const double radius = 0.03;
  const LocalRelaxationResult r =
      relax_patch_after_cut(p, LocalRelaxationParams{radius}, path, held, target, scratch, local);
  ASSERT_TRUE(r.relaxed);
  int32_t inside = 0, moved = 0;
  for (int32_t i = 0; i < start.verts.size(); ++i) {
    const Vec2 q = start.verts.rest[i];
    const double d = q.y() < from.y() ? (q - from).norm() : q.y() > to.y() ? (q - to).norm() : std::abs(q.x() - 0.1);
    if (d > radius) {  // no vertex was cut (no kNew): the patch is the disc-swept segment exactly
      EXPECT_EQ(local.verts.x[i], start.verts.x[i]) << "vertex " << i;
      EXPECT_EQ(local.verts.v[i], start.verts.v[i]) << "vertex " << i;
    } else {
      ++inside;
      if (local.verts.x[i] != start.verts.x[i]) ++moved;
    }
  }
  EXPECT_EQ(r.free_vertices, inside);
  EXPECT_EQ(moved, inside) << "every free vertex took the step";
  // The scratch leaves no mark behind: a second call on the result gives the same as a fresh scratch.
  Sheet again = local, fresh = local;
  LocalRelaxationScratch other;
  ASSERT_TRUE(relax_patch_after_cut(p, LocalRelaxationParams{radius}, path, held, target, scratch, again).relaxed);
  ASSERT_TRUE(relax_patch_after_cut(p, LocalRelaxationParams{radius}, path, held, target, other, fresh).relaxed);
  EXPECT_EQ(again.verts.x, fresh.verts.x);
  EXPECT_EQ(again.verts.v, fresh.verts.v);
}

TEST(LocalRelaxation, CutLipsOpenMoreAsThePatchGrowsUpToTheFullSubstep) {
  ImplicitParams p;
  p.gravity = Vec3::Zero();
  std::vector<int32_t> held;
  std::vector<Vec3> target;
  Sheet cut = held_sheet(p, 0.002, 200, held, target);  // at rest
  // A tear from the bottom edge's middle, across the pull: its lips carried the stretch and spring apart.
  const int32_t p0 = nearest_boundary_vertex(cut, Vec2(0.1, 0));
  ASSERT_GE(p0, 0);
  const CutResult c = cut_tear_segment(p0, Vec2(0.1, 0.06), Vec2::Zero(), 0, RemeshParams{}, cut);
  ASSERT_TRUE(c.cut);
  ASSERT_FALSE(c.reached_boundary);
  pulled_edges(cut, 0.002, held, target);  // the cut may renumber vertices: the edges' ids again
  const std::vector<Vec2> path = {Vec2(0.1, 0), c.end};
  ASSERT_LT(largest_lip_opening(cut), 1e-12) << "the cut alone moves nothing";

  // The full substep is nearly quasi-static here (h²K ≫ M: a stress wave crosses the sheet within one
  // substep), so the lips' opening is the elastic field of the whole cut, ~its length across. A patch holds
  // its rim, so it opens the lips less, and the more so the smaller it is; covering the cut's surroundings
  // it is the full step's. Measured: 0.27 / 0.37 / 0.73 / 0.98 / 1.00 of it at 1 / 3 / 6 / 10 / 15 cm.
  Sheet full = cut;
  ImplicitSolverPtr solver;
  ASSERT_TRUE(implicit_substep(p, held, target, solver, full));
  const double open_full = largest_lip_opening(full);
  EXPECT_GT(open_full, 1e-5);
  double previous = 0;
  for (const double radius : {0.01, 0.03, 0.06, 0.1, 0.15}) {
    Sheet local = cut;
    LocalRelaxationScratch scratch;
    const LocalRelaxationResult r =
        relax_patch_after_cut(p, LocalRelaxationParams{radius}, path, held, target, scratch, local);
    ASSERT_TRUE(r.relaxed);
    const double opening = largest_lip_opening(local);
    EXPECT_GT(opening, previous) << "radius " << radius;
    previous = opening;
    if (radius <= 0.03) {
      EXPECT_LT(r.free_vertices, cut.verts.size() / 4) << "a patch, not the sheet";
      EXPECT_GT(opening, 0.2 * open_full) << "the lips open";
    }
  }
  EXPECT_NEAR(previous, open_full, 0.02 * open_full);
}
