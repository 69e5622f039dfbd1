// Projective dynamics integration: hanging sheet at rest, energy decay, yanked corner, determinism, solver
// reuse, NaN guard. Its speed is benchmarked (bench/frame_bench.cpp: BM_PhysicsFrameProjective).
#include "systems/integrate.hpp"
#include "systems/topology.hpp"

#include "test_meshes.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <random>

namespace pt {
namespace {

using Mat32 = Eigen::Matrix<double, 3, 2>;

// A W x H rectangle as an nx x ny grid, cells split into two counter-clockwise triangles with alternating
// diagonals, interior vertices jittered by `jitter` cell sizes. Flat in z = 0, at rest.
Sheet make_grid(double W, double H, int nx, int ny, double jitter = 0.2, uint32_t seed = 1) {
  return test::alternating_grid(W, H, nx, ny, jitter, seed);
}

int32_t vertex_at(const Sheet& s, Vec2 uv) {
  int32_t best = 0;
  for (int32_t v = 1; v < s.verts.size(); ++v)
    if ((s.verts.rest[v] - uv).norm() < (s.verts.rest[best] - uv).norm()) best = v;
  return best;
}

double max_strain(const Sheet& s) {
  double worst = 0;
  for (int32_t t = 0; t < s.tris.size(); ++t) {
    const Mat32 F = deformation_gradient(s.verts.x, s.tris.tri[t], s.tris.rest_inv[t]);
    const Eigen::SelfAdjointEigenSolver<Mat2> eig(F.transpose() * F);
    for (int i = 0; i < 2; ++i) worst = std::max(worst, std::abs(std::sqrt(std::max(0.0, eig.eigenvalues()[i])) - 1));
  }
  return worst;
}

double max_speed(const Sheet& s) {
  double m = 0;
  for (const Vec3& v : s.verts.v) m = std::max(m, v.norm());
  return m;
}

bool all_finite(const Sheet& s) {
  for (int32_t v = 0; v < s.verts.size(); ++v)
    if (!s.verts.x[v].allFinite() || !s.verts.v[v].allFinite()) return false;
  return true;
}

double total_energy(const Sheet& s, const std::vector<BendingStencil>& st) {
  double kinetic = 0;
  for (int32_t v = 0; v < s.verts.size(); ++v) kinetic += 0.5 * s.verts.mass[v] * s.verts.v[v].squaredNorm();
  return kinetic + membrane_energy(s.verts.x, s.tris.tri, s.tris.rest_inv, s.tris.rest_area, membrane_params(s.material)) +
         bending_energy(s.verts.x, st);
}

// Holds the listed vertices (as fingers, so prepare_projective_solver sees them) at `targets`.
void hold(Sheet& s, const std::vector<int32_t>& verts) {
  s.fingers.clear();
  for (int32_t v : verts) {
    Finger f;
    f.vertex = v;
    f.start = f.target = s.verts.x[v];
    s.fingers.push_back(f);
  }
}

struct Sim {
  IntegrateParams params;
  ProjectiveSolverPtr solver;
  std::vector<int32_t> held;
  std::vector<Vec3> target;
  bool step(Sheet& s) {
    held.clear();
    target.clear();
    for (const Finger& f : s.fingers) {
      held.push_back(f.vertex);
      target.push_back(f.target);
    }
    prepare_projective_solver(s, params, solver);
    return integrate_substep(params, held, target, *solver, s);
  }
};

struct HangResult {
  double speed, strain, worst_strain, zmin;
};

HangResult hang(int iterations, double seconds) {
  Sheet s = make_grid(0.2, 0.2, 10, 10);  // 200 triangles
  hold(s, {vertex_at(s, Vec2(0, 0.2)), vertex_at(s, Vec2(0.2, 0.2))});
  Sim sim;
  sim.params.iterations = iterations;
  double worst_strain = 0;
  const int steps = static_cast<int>(300 * seconds);
  for (int k = 0; k < steps; ++k) {
    EXPECT_TRUE(sim.step(s)) << "substep " << k;
    if (k >= steps / 2) worst_strain = std::max(worst_strain, max_strain(s));
  }
  EXPECT_TRUE(all_finite(s));
  EXPECT_EQ(projective_solver_stats(*sim.solver).factorizations, 1);
  HangResult r{max_speed(s), max_strain(s), worst_strain, 0};
  for (const Vec3& p : s.verts.x) r.zmin = std::min(r.zmin, p.z());
  std::printf("[ hanging ] %d iterations, after %.0f s: max |v| = %.3g m/s, max strain = %.3g (worst over the last "
              "half %.3g), lowest z = %.4f m (fully hanging: about -0.2)\n",
              iterations, seconds, r.speed, r.strain, r.worst_strain, r.zmin);
  return r;
}

TEST(Integrate, HangingSheetSettlesWithSmallStrain) {
  // Default 2 iterations: strain < 1% and it comes to rest, but PD is so slow in the bending directions of
  // this stiff membrane (E e / (ρ e) per area ≈ 5e6 m²/s²) that after 4 s the sheet hangs only ~0.11 m.
  const HangResult a = hang(2, 4);
  EXPECT_LT(a.speed, 0.02);
  EXPECT_LT(a.strain, 0.01);
  EXPECT_LT(a.worst_strain, 0.01);
  EXPECT_LT(a.zmin, -0.08);
  // 10 iterations: strain ~0.2% and it hangs (lowest point ~-0.18 m after 4 s).
  const HangResult b = hang(10, 4);
  EXPECT_LT(b.speed, 0.02);
  EXPECT_LT(b.strain, 0.005);
  EXPECT_LT(b.zmin, -0.15);
  EXPECT_GT(b.zmin, -0.21);
}

// Modes: 0 stretched by 0.5% and sheared; 1 rolled onto a cylinder (isometric: bending energy only);
// 2 a non-isometric bump (membrane and bending both loaded).
void deform(Sheet& s, int mode) {
  for (int32_t v = 0; v < s.verts.size(); ++v) {
    const Vec2 p = s.verts.rest[v];
    if (mode == 0) s.verts.x[v] = Vec3(1.005 * p.x() + 0.002 * p.y(), p.y(), 0);
    if (mode == 1) s.verts.x[v] = Vec3(0.05 * std::sin(p.x() / 0.05), p.y(), 0.05 * (1 - std::cos(p.x() / 0.05)));
    if (mode == 2) s.verts.x[v] = Vec3(p.x(), p.y(), 0.01 * std::sin(31.4 * p.x()) * std::sin(31.4 * p.y()));
  }
}

struct EnergyRun {
  double initial = 0, final = 0, worst_growth = 0;  // worst relative growth from one substep to the next
  int worst_step = -1;
};

EnergyRun run_energy(int mode, int iterations) {
  Sheet s = make_grid(0.1, 0.1, 8, 8, 0.2, 3);
  // Projective dynamics has no strain-limit term, and these bounds are for paper's full in-plane modulus.
  s.material.strain_limit = 1e9;
  s.material.membrane_scale = 1;
  std::vector<BendingStencil> st;
  build_bending_stencils(s.verts.rest, s.topo.hinges, bending_stiffness(s.material), st);
  deform(s, mode);
  Sim sim;
  sim.params.gravity = Vec3::Zero();
  sim.params.iterations = iterations;
  EnergyRun r;
  double prev = total_energy(s, st);
  r.initial = prev;
  for (int k = 0; k < 600; ++k) {
    EXPECT_TRUE(sim.step(s));
    const double e = total_energy(s, st);
    // Growth above round-off (the energy falls ~20 orders of magnitude in mode 0).
    const double growth = (e - prev - 1e-12 * r.initial) / prev;
    if (growth > r.worst_growth) {
      r.worst_growth = growth;
      r.worst_step = k;
    }
    prev = e;
  }
  r.final = prev;
  std::printf("[ energy ] mode %d, %d iterations: %.4g J -> %.4g J after 2 s, worst growth %.3g%% (substep %d)\n",
              mode, iterations, r.initial, r.final, 100 * r.worst_growth, r.worst_step);
  return r;
}

TEST(Integrate, EnergyNeverGrowsWithoutGravity) {
  // Membrane-dominated (stretched): strictly non-increasing with 2 iterations.
  const EnergyRun stretched = run_energy(0, 2);
  EXPECT_LE(stretched.worst_growth, 1e-9) << "substep " << stretched.worst_step;
  EXPECT_LT(stretched.final, 0.5 * stretched.initial);
  // Bending-dominated (rolled): the truncated PD iteration lets the total rise by ~0.5% at one substep
  // (measured 0.47% at substep 31); bounded here at 1%, and it decays overall.
  const EnergyRun rolled = run_energy(1, 2);
  EXPECT_LE(rolled.worst_growth, 0.01) << "substep " << rolled.worst_step;
  EXPECT_LT(rolled.final, 0.5 * rolled.initial);
}

// A non-isometric bump: PD with a truncated number of iterations is not the exact backward Euler step, and
// the membrane energy left in a crumpled state can rise a little from one substep to the next (PD converges
// slowly in the bending directions of a stiff membrane). Logged; only gross growth is an error.
TEST(Integrate, EnergyOfNonIsometricBumpDecaysOverall) {
  const EnergyRun r = run_energy(2, 2);
  EXPECT_LT(r.worst_growth, 0.5);
  EXPECT_LT(r.final, 0.01 * r.initial);
}

TEST(Integrate, YankedCornerStaysFiniteAndSettles) {
  Sheet s = make_grid(0.2, 0.2, 10, 10, 0.2, 5);
  hold(s, {vertex_at(s, Vec2(0.2, 0.2))});
  Sim sim;
  const double h = sim.params.dt;
  const Vec3 start = s.fingers[0].target, dir = Vec3(1, 0.5, 0.3).normalized();
  double worst_strain = 0;
  for (int k = 1; k <= 300 * 4; ++k) {
    const double t = k * h;
    s.fingers[0].target = start + 5.0 * std::min(t, 0.2) * dir;  // 5 m/s for 0.2 s, then holds
    ASSERT_TRUE(sim.step(s)) << "substep " << k;
    ASSERT_TRUE(all_finite(s)) << "substep " << k;
    worst_strain = std::max(worst_strain, max_strain(s));
  }
  const double speed = max_speed(s), strain = max_strain(s);
  std::printf("[ yank ] worst strain during the run %.3g; after 3.8 s still: max |v| = %.3g m/s, strain %.3g\n",
              worst_strain, speed, strain);
  EXPECT_LT(speed, 0.05);
  EXPECT_LT(strain, 0.01);
}

// A runner that cuts [0, count) into ranges of 3 and runs them last to first.
void run_reverse_small(int32_t count, int32_t /*grain*/, const RangeTask& task) {
  for (int32_t e = count; e > 0; e -= 3) task(std::max(0, e - 3), e);
}

TEST(Integrate, DeterministicWhateverTheRanges) {
  Sheet a = make_grid(0.2, 0.2, 10, 10, 0.2, 6);
  hold(a, {vertex_at(a, Vec2(0, 0.2))});
  Sheet b = a;
  Sim sa, sb;
  sb.params.run = run_reverse_small;
  for (int k = 0; k < 200; ++k) {
    a.fingers[0].target += Vec3(0.001, 0, 0.002);
    b.fingers[0].target += Vec3(0.001, 0, 0.002);
    ASSERT_TRUE(sa.step(a));
    ASSERT_TRUE(sb.step(b));
  }
  for (int32_t v = 0; v < a.verts.size(); ++v) {
    ASSERT_EQ(a.verts.x[v], b.verts.x[v]) << "vertex " << v;
    ASSERT_EQ(a.verts.v[v], b.verts.v[v]) << "vertex " << v;
  }
}

TEST(Integrate, FactorisationReusedUntilSomethingChanges) {
  Sheet s = make_grid(0.1, 0.1, 5, 5);
  hold(s, {0});
  Sim sim;
  for (int k = 0; k < 5; ++k) sim.step(s);
  const ProjectiveSolver* first = sim.solver.get();
  EXPECT_EQ(projective_solver_stats(*sim.solver).factorizations, 1);
  hold(s, {0, 5});  // held set changes
  sim.step(s);
  EXPECT_EQ(projective_solver_stats(*sim.solver).factorizations, 2);
  sim.params.dt = 1.0 / 600;  // dt changes
  sim.step(s);
  EXPECT_EQ(projective_solver_stats(*sim.solver).factorizations, 3);
  refresh_after_topology_change(s);  // topology version bump
  sim.step(s);
  EXPECT_EQ(projective_solver_stats(*sim.solver).factorizations, 4);
  for (int k = 0; k < 5; ++k) sim.step(s);
  EXPECT_EQ(projective_solver_stats(*sim.solver).factorizations, 4);
  EXPECT_EQ(sim.solver.get(), first);
  // A caller whose held list differs from the fingers still gets a consistent solve.
  std::vector<int32_t> held{3};
  std::vector<Vec3> target{s.verts.x[3] + Vec3(0, 0, 0.01)};
  ASSERT_TRUE(integrate_substep(sim.params, held, target, *sim.solver, s));
  EXPECT_EQ(s.verts.x[3], target[0]);
  EXPECT_EQ(projective_solver_stats(*sim.solver).factorizations, 5);
}

TEST(Integrate, HeldVerticesFollowTargets) {
  Sheet s = make_grid(0.1, 0.1, 5, 5);
  hold(s, {0, 35});
  Sim sim;
  const Vec3 x0 = s.verts.x[0];
  s.fingers[0].target = x0 + Vec3(0.003, 0, 0.001);
  ASSERT_TRUE(sim.step(s));
  EXPECT_EQ(s.verts.x[0], s.fingers[0].target);
  EXPECT_LT((s.verts.v[0] - Vec3(0.003, 0, 0.001) / sim.params.dt).norm(), 1e-9);
}

TEST(Integrate, NonFiniteResultKeepsThePreviousState) {
  Sheet s = make_grid(0.1, 0.1, 5, 5);
  hold(s, {0});
  Sim sim;
  for (int k = 0; k < 10; ++k) ASSERT_TRUE(sim.step(s));
  const std::vector<Vec3> x = s.verts.x, v = s.verts.v;
  s.fingers[0].target = Vec3(std::nan(""), 0, 0);
  EXPECT_FALSE(sim.step(s));
  EXPECT_FALSE(projective_solver_stats(*sim.solver).ok);
  EXPECT_EQ(projective_solver_stats(*sim.solver).failures, 1);
  for (int32_t i = 0; i < s.verts.size(); ++i) {
    EXPECT_EQ(s.verts.x[i], x[i]);
    EXPECT_EQ(s.verts.v[i], v[i]);
  }
  s.fingers[0].target = x[0];
  EXPECT_TRUE(sim.step(s));
  EXPECT_TRUE(projective_solver_stats(*sim.solver).ok);
}

}  // namespace
}  // namespace pt
