// Membrane forces: gradient consistency, invariances, patch test, degenerate triangles. The kernel's speed is
// benchmarked (bench/frame_bench.cpp: BM_MembraneForces, BM_GatherCornerForces).
#include "systems/physics/membrane_forces.hpp"
#include "systems/common/topology.hpp"

#include "tests/test_meshes.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <random>

namespace pt {
namespace {

using Mat32 = Eigen::Matrix<double, 3, 2>;

// A W x H rectangle as an nx x ny grid, each cell split into two counter-clockwise triangles (diagonals
// alternate so the mesh has no preferred direction); interior vertices jittered by `jitter` cell sizes.
Sheet make_grid(double W, double H, int nx, int ny, double jitter = 0, uint32_t seed = 1) {
  return test::alternating_grid(W, H, nx, ny, jitter, seed);
}

MembraneParams paper_params() { return membrane_params(Material{}); }

struct OneTri {
  std::vector<Vec3> x;
  std::vector<Tri> tri{{0, 1, 2}};
  std::vector<Mat2> rest_inv;
  std::vector<double> rest_area;
};

OneTri random_triangle(std::mt19937& rng, double deform) {
  std::uniform_real_distribution<double> u(-1, 1);
  OneTri o;
  std::vector<Vec2> rest;
  do {
    rest = {Vec2(u(rng), u(rng)) * 0.01, Vec2(u(rng), u(rng)) * 0.01, Vec2(u(rng), u(rng)) * 0.01};
    if ((rest[1] - rest[0]).x() * (rest[2] - rest[0]).y() - (rest[1] - rest[0]).y() * (rest[2] - rest[0]).x() < 0)
      std::swap(rest[1], rest[2]);
  } while ((rest[1] - rest[0]).x() * (rest[2] - rest[0]).y() - (rest[1] - rest[0]).y() * (rest[2] - rest[0]).x() <
           2e-5);
  update_rest_data(rest, o.tri, o.rest_inv, o.rest_area);
  const Eigen::Matrix3d rot = Eigen::AngleAxisd(3 * u(rng), Vec3(u(rng), u(rng), u(rng)).normalized()).toRotationMatrix();
  for (const Vec2& r : rest) {
    const Vec3 p(r.x(), r.y(), 0);
    o.x.push_back(rot * p + Vec3(u(rng), u(rng), u(rng)) * 0.01 * deform);
  }
  return o;
}

// Central differences of the energy at step h against the kernel's corner forces, to rel_tol of the largest.
void expect_forces_are_minus_energy_gradient(const OneTri& o, const MembraneParams& params, double h, double rel_tol,
                                             int trial) {
  std::vector<std::array<Vec3, 3>> cf(1);
  compute_membrane_forces(o.x, o.tri, o.rest_inv, o.rest_area, params, 0, 1, cf);
  double max_f = 0;
  for (const Vec3& f : cf[0]) max_f = std::max(max_f, f.norm());
  for (int c = 0; c < 3; ++c)
    for (int d = 0; d < 3; ++d) {
      std::vector<Vec3> xp = o.x, xm = o.x;
      xp[c][d] += h;
      xm[c][d] -= h;
      const double g = (membrane_energy(xp, o.tri, o.rest_inv, o.rest_area, params) -
                        membrane_energy(xm, o.tri, o.rest_inv, o.rest_area, params)) / (2 * h);
      EXPECT_NEAR(cf[0][c][d], -g, rel_tol * max_f) << "trial " << trial << " corner " << c << " dim " << d;
    }
}

TEST(MembraneForces, LameParametersArePlaneStressOfTheEffectiveModulus) {
  const Material m;
  const MembraneParams p = membrane_params(m);
  const double young = m.young * m.membrane_scale;
  EXPECT_NEAR(p.mu, young / (2 * (1 + m.poisson)), 1e-6);
  EXPECT_NEAR(p.lambda, young * m.poisson / (1 - m.poisson * m.poisson), 1e-3);
  EXPECT_EQ(p.thickness, m.thickness);
  // Past the strain limit a principal direction is as stiff as paper: μ + μ_lim = the full modulus' μ.
  EXPECT_NEAR(p.mu + p.limit_mu, m.young / (2 * (1 + m.poisson)), 1e-3);
  EXPECT_EQ(p.strain_limit, m.strain_limit);
}

// The strain-limit term against its closed form: a uniaxial stretch ε along a direction at angle a of the
// rest frame has principal strains (ε, 0), so W_lim = μ_lim (ε − ε_lim)² and τ = 2 μ_lim (ε − ε_lim) v vᵀ.
TEST(MembraneForces, StrainLimitTermOfAUniaxialStretch) {
  MembraneParams p = paper_params();
  p.compression_relief = 0;  // the stretch limit alone (the second principal strain is 0 up to rounding)
  for (const double a : {0.0, 0.4, 1.3, 2.9})
    for (const double eps : {0.005, 0.012, 0.03}) {
      const Vec2 v(std::cos(a), std::sin(a));
      const Mat2 strain = eps * v * v.transpose();
      Mat2 tau = Mat2::Zero();
      StrainLimitTangent tangent;
      const double w = strain_limit_term(strain, p, tau, &tangent);
      const double x = std::max(0.0, eps - p.strain_limit);
      EXPECT_NEAR(w, p.limit_mu * x * x, 1e-9 * p.limit_mu * 1e-4);
      EXPECT_LT((tau - 2 * p.limit_mu * x * v * v.transpose()).norm(), 1e-9 * p.limit_mu);
      EXPECT_EQ(tangent.count, x > 0 ? 1 : 0);
      if (x > 0) {
        EXPECT_NEAR(std::abs(tangent.direction[0].dot(v)), 1.0, 1e-12);
      }
    }
}

// Forces of triangles stretched past the strain limit are still minus the energy gradient (finite
// differences), and a stretch beyond the limit costs the full modulus: the force of 3% is far more than 3x
// that of 1%.
TEST(MembraneForces, StrainLimitedForcesAreMinusEnergyGradient) {
  const MembraneParams params = paper_params();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 40; ++trial) {
    OneTri o = random_triangle(rng, 0);
    // A stretch of 1–4% along a random direction, then a rigid motion (random_triangle's).
    const Vec2 d = Vec2(u(rng), u(rng)).normalized();
    const double eps = 0.01 + 0.03 * std::abs(u(rng));
    const Mat2 Dm = o.rest_inv[0].inverse();
    const Vec2 r1 = Dm.col(0), r2 = Dm.col(1);
    const Mat2 stretch = Mat2::Identity() + eps * d * d.transpose();
    const Vec2 s1 = stretch * r1, s2 = stretch * r2;
    o.x[1] = o.x[0] + Vec3(s1.x(), s1.y(), 0.001 * u(rng));
    o.x[2] = o.x[0] + Vec3(s2.x(), s2.y(), 0.001 * u(rng));
    expect_forces_are_minus_energy_gradient(o, params, 1e-8, 2e-5, trial);
  }
}

// Compression relief: forces stay minus the energy gradient (finite differences) for triangles squeezed
// by 0.5-8% along one direction and stretched or squeezed along the other, across the relief's kinks
// (0, the compression limit); a squeeze keeps 1 − relief of its stress below the limit.
TEST(MembraneForces, CompressionReliefForcesAreMinusEnergyGradient) {
  MembraneParams params = paper_params();
  params.compression_relief = 0.9;
  params.compression_limit = 0.05;
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 60; ++trial) {
    OneTri o = random_triangle(rng, 0);
    const Vec2 d = Vec2(u(rng), u(rng)).normalized(), n(-d.y(), d.x());
    const double squeeze = 0.005 + 0.075 * std::abs(u(rng)), other = 0.03 * u(rng);
    const Mat2 Dm = o.rest_inv[0].inverse();
    const Mat2 strain = Mat2::Identity() - squeeze * d * d.transpose() + other * n * n.transpose();
    const Vec2 s1 = strain * Dm.col(0), s2 = strain * Dm.col(1);
    o.x[1] = o.x[0] + Vec3(s1.x(), s1.y(), 0.0005 * u(rng));
    o.x[2] = o.x[0] + Vec3(s2.x(), s2.y(), 0.0005 * u(rng));
    expect_forces_are_minus_energy_gradient(o, params, 1e-9, 2e-5, trial);
  }
  // A strain of −1% along x alone: the relief leaves a tenth of the linear stress along x.
  const MembraneParams stiff = paper_params();
  Mat2 strain;
  strain << -0.01, 0, 0, 0;
  Mat2 tau = Mat2::Zero();
  strain_limit_term(strain, params, tau);
  const double linear = 2 * stiff.mu * -0.01 + stiff.lambda * -0.01;
  EXPECT_NEAR(linear + tau(0, 0), 0.1 * linear, 1e-9 * std::abs(linear));
}


// The tangent the implicit step uses for the relief and the limits (StrainLimitTangent) is the derivative
// of the stress τ(E) = 2μE + λ tr(E) I + the terms' τ, by central differences, in the principal frame
// (a diagonal perturbation there leaves the principal directions where they are): compressed on both
// axes, on one, past the compression limit, and stretched past the strain limit.
TEST(MembraneForces, ReliefAndLimitTangentsAreTheStressDerivative) {
  MembraneParams params = paper_params();
  params.compression_relief = 0.95;
  params.compression_limit = 0.05;
  params.strain_limit = 0.02;
  params.tangent_compression_floor = 0;  // the exact derivative (the floor is checked below)
  auto stress = [&](const Mat2& e) {
    Mat2 tau = 2 * params.mu * e + params.lambda * e.trace() * Mat2::Identity();
    strain_limit_term(e, params, tau);
    return tau;
  };
  const double cases[][2] = {{-0.01, -0.004}, {-0.01, 0.003}, {0.004, -0.02}, {-0.06, 0.001}, {0.03, -0.001}};
  for (const auto& c : cases)
    for (const double turn : {0.0, 0.7}) {
      const Vec2 v(std::cos(turn), std::sin(turn)), w(-v.y(), v.x());
      const Mat2 e = c[0] * v * v.transpose() + c[1] * w * w.transpose();
      Mat2 tau = Mat2::Zero();
      StrainLimitTangent tangent;
      strain_limit_term(e, params, tau, &tangent);
      // The tangent's stiffness along the principal axes a, b: d τ_aa / d e_bb.
      auto tangent_ab = [&](const Vec2& a, const Vec2& b) {
        double k = params.lambda * tangent.trace_scale + (a == b ? 2 * params.mu : 0);
        for (int i = 0; i < tangent.count; ++i)
          k += tangent.modulus[i] * std::pow(a.dot(tangent.direction[i]), 2) * std::pow(b.dot(tangent.direction[i]), 2);
        return k;
      };
      const double h = 1e-7;
      for (const Vec2& b : {v, w}) {
        const Mat2 d = stress(e + h * b * b.transpose()) - stress(e - h * b * b.transpose());
        for (const Vec2& a : {v, w}) {
          const double fd = a.dot(d * a) / (2 * h), k = tangent_ab(a, b);
          EXPECT_NEAR(k, fd, 1e-5 * (2 * params.mu + params.lambda)) << c[0] << " " << c[1] << " turn " << turn;
        }
      }
    }
  // With the floor, a direction compressed within the limit keeps that fraction of 2μ, and the trace of λ.
  params.tangent_compression_floor = 0.2;
  Mat2 e;
  e << -0.01, 0, 0, 0.002;
  Mat2 tau = Mat2::Zero();
  StrainLimitTangent tangent;
  strain_limit_term(e, params, tau, &tangent);
  ASSERT_EQ(tangent.count, 1);
  EXPECT_NEAR(2 * params.mu + tangent.modulus[0], 0.2 * 2 * params.mu, 1e-9 * params.mu);
  EXPECT_NEAR(tangent.trace_scale, 0.2, 1e-12);
}
TEST(MembraneForces, StrainLimitStiffensPastTheLimit) {
  const MembraneParams params = paper_params();
  auto stress_at = [&](double eps) {
    OneTri o;
    std::vector<Vec2> rest{Vec2(0, 0), Vec2(0.01, 0), Vec2(0, 0.01)};
    update_rest_data(rest, o.tri, o.rest_inv, o.rest_area);
    o.x = {Vec3(0, 0, 0), Vec3(0.01 * (1 + eps), 0, 0), Vec3(0, 0.01, 0)};
    std::vector<std::array<Vec3, 3>> cf(1);
    compute_membrane_forces(o.x, o.tri, o.rest_inv, o.rest_area, params, 0, 1, cf);
    return cf[0][1].x();
  };
  const double limit = params.strain_limit;
  const double below = stress_at(0.5 * limit), at = stress_at(limit), past = stress_at(1.5 * limit);
  EXPECT_NEAR(below / at, 0.5, 1e-6);  // linear below the limit
  // Past it the slope is the full modulus: (past − at) / (at / ε_lim · Δε) = (μ + μ_lim) / μ.
  const double slope_ratio = (past - at) / (at / limit * (0.5 * limit));
  const double expected = 1 + params.limit_mu * 2 / (2 * params.mu + params.lambda);
  EXPECT_NEAR(slope_ratio, expected, 0.02 * expected);
}

TEST(MembraneForces, MaxPrincipalStrain) {
  OneTri o;
  std::vector<Vec2> rest{Vec2(0, 0), Vec2(0.01, 0), Vec2(0, 0.01)};
  update_rest_data(rest, o.tri, o.rest_inv, o.rest_area);
  const Eigen::Matrix3d rot = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  o.x = {Vec3(0, 0, 0), rot * Vec3(0.01, 0, 0), rot * Vec3(0, 0.0103, 0)};
  EXPECT_NEAR(max_principal_strain(o.x, o.tri, o.rest_inv, 0, 1), 0.03, 1e-9);
  o.x = {Vec3(0, 0, 0), Vec3(0.0099, 0, 0), Vec3(0, 0.0098, 0)};  // compressed only
  EXPECT_EQ(max_principal_strain(o.x, o.tri, o.rest_inv, 0, 1), 0.0);
}

TEST(MembraneForces, PolarRotationHasOrthonormalColumnsAndSymmetricStretch) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int k = 0; k < 200; ++k) {
    Mat32 F;
    for (int i = 0; i < 6; ++i) F(i) = u(rng);
    const Mat32 R = polar_rotation(F);
    EXPECT_LT((R.transpose() * R - Mat2::Identity()).norm(), 1e-12);
    const Mat2 S = R.transpose() * F;
    EXPECT_LT(std::abs(S(0, 1) - S(1, 0)), 1e-12);
    EXPECT_GT(S.trace(), 0);
    EXPECT_GE(S.determinant(), -1e-14);  // positive semi-definite stretch: R is the polar factor
  }
}

TEST(MembraneForces, ForcesAreMinusEnergyGradient) {
  std::mt19937 rng(7);
  const MembraneParams params = paper_params();
  for (int trial = 0; trial < 50; ++trial) {
    OneTri o = random_triangle(rng, trial < 25 ? 0.05 : 0.5);
    expect_forces_are_minus_energy_gradient(o, params, 1e-7 * 0.01, 1e-6, trial);
  }
}

TEST(MembraneForces, ZeroAtRestAndUnderRigidMotion) {
  Sheet s = make_grid(0.2, 0.1, 8, 4, 0.3);
  const MembraneParams params = paper_params();
  const int32_t nt = s.tris.size();
  const Eigen::Matrix3d rot = Eigen::AngleAxisd(1.1, Vec3(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
  for (int pass = 0; pass < 2; ++pass) {
    if (pass == 1)
      for (Vec3& p : s.verts.x) p = rot * p + Vec3(0.3, -2, 5);
    compute_membrane_forces(s.verts.x, s.tris.tri, s.tris.rest_inv, s.tris.rest_area, params, 0, nt,
                            s.tris.corner_force);
    // Scale: the force of a 1e-3 strain on a cell edge (E e ε L ≈ 4e5 · 1e-3 · 0.025 = 10 N).
    for (int32_t t = 0; t < nt; ++t)
      for (const Vec3& f : s.tris.corner_force[t]) EXPECT_LT(f.norm(), 1e-6) << "pass " << pass;
    EXPECT_LT(membrane_energy(s.verts.x, s.tris.tri, s.tris.rest_inv, s.tris.rest_area, params), 1e-15);
  }
}

TEST(MembraneForces, PatchTestUniformStretch) {
  const double eps = 1e-3;
  Sheet s = make_grid(0.2, 0.1, 10, 5, 0.3, 5);
  for (int32_t i = 0; i < s.verts.size(); ++i)
    s.verts.x[i] = Vec3((1 + eps) * s.verts.rest[i].x(), s.verts.rest[i].y(), 0);
  const MembraneParams params = paper_params();
  const int32_t nt = s.tris.size();
  compute_membrane_forces(s.verts.x, s.tris.tri, s.tris.rest_inv, s.tris.rest_area, params, 0, nt,
                          s.tris.corner_force);
  // First Piola stress × thickness: P = e (2μ (F − R) + λ tr(RᵀF − I) R) with R = I, F = diag(1 + ε, 1).
  const double pxx = params.thickness * (2 * params.mu + params.lambda) * eps;
  const double pyy = params.thickness * params.lambda * eps;
  for (int32_t t = 0; t < nt; ++t) {
    // Recover P from the corner forces: [f1 f2] = −A P Bᵀ  ⇒  P = −[f1 f2] B⁻ᵀ / A.
    Mat32 H;
    H.col(0) = s.tris.corner_force[t][1];
    H.col(1) = s.tris.corner_force[t][2];
    const Mat32 P = -H * s.tris.rest_inv[t].transpose().inverse() / s.tris.rest_area[t];
    EXPECT_NEAR(P(0, 0), pxx, 1e-9 * pxx);
    EXPECT_NEAR(P(1, 1), pyy, 1e-9 * pxx);
    EXPECT_NEAR(P(0, 1), 0, 1e-9 * pxx);
    EXPECT_NEAR(P(1, 0), 0, 1e-9 * pxx);
    EXPECT_NEAR(P.row(2).norm(), 0, 1e-9 * pxx);
  }
  std::vector<Vec3> f(s.verts.size());
  gather_corner_forces(s.topo, s.tris.tri, s.tris.corner_force, 0, s.verts.size(), f);
  const double scale = pxx * 0.02;  // force of the stress on one cell edge
  Vec3 total = Vec3::Zero();
  for (int32_t v = 0; v < s.verts.size(); ++v) {
    total += f[v];
    if (!(s.verts.flags[v] & kBoundary)) {
      EXPECT_LT(f[v].norm(), 1e-9 * scale) << "interior vertex " << v;
    }
  }
  EXPECT_LT(total.norm(), 1e-9 * scale);
  // The right edge (u = W) carries the traction pxx · H in x.
  double right = 0;
  for (int32_t v = 0; v < s.verts.size(); ++v)
    if (s.verts.rest[v].x() > 0.2 - 1e-12) right += f[v].x();
  EXPECT_NEAR(right, -pxx * 0.1, 1e-9 * pxx);
}

TEST(MembraneForces, DegenerateTrianglesGiveFiniteForces) {
  OneTri o;
  std::vector<Vec2> rest{Vec2(0, 0), Vec2(0.01, 0), Vec2(0, 0.01)};
  update_rest_data(rest, o.tri, o.rest_inv, o.rest_area);
  const MembraneParams params = paper_params();
  const std::vector<std::vector<Vec3>> cases{
      {Vec3(0, 0, 0), Vec3(0, 0, 0), Vec3(0, 0, 0)},                  // point
      {Vec3(0, 0, 0), Vec3(0.01, 0, 0), Vec3(0.005, 0, 0)},           // line, inside the edge
      {Vec3(0, 0, 0), Vec3(0.01, 0, 0), Vec3(0.02, 0, 0)},            // line, beyond
      {Vec3(0, 0, 0), Vec3(0, 0, 0), Vec3(0, 0.01, 0)},               // edge collapsed
      {Vec3(0, 0, 0), Vec3(0.01, 0, 0), Vec3(0.0, 1e-12, 0)},         // nearly flat
      {Vec3(0, 0, 0), Vec3(0.01, 0, 0), Vec3(0.0, -0.01, 0)},         // inverted in the plane
      {Vec3(0, 0, 0), Vec3(0.01, 0, 0), Vec3(0.0, 1e-7, 1e-7)},       // nearly flat, off plane
  };
  for (size_t k = 0; k < cases.size(); ++k) {
    o.x = cases[k];
    std::vector<std::array<Vec3, 3>> cf(1);
    compute_membrane_forces(o.x, o.tri, o.rest_inv, o.rest_area, params, 0, 1, cf);
    for (const Vec3& f : cf[0]) EXPECT_TRUE(f.allFinite()) << "case " << k;
    EXPECT_LT((cf[0][0] + cf[0][1] + cf[0][2]).norm(), 1e-9 * (cf[0][0].norm() + 1)) << "case " << k;
    EXPECT_TRUE(std::isfinite(membrane_energy(o.x, o.tri, o.rest_inv, o.rest_area, params))) << "case " << k;
    const Mat32 R = polar_rotation(deformation_gradient(o.x, o.tri[0], o.rest_inv[0]));
    EXPECT_TRUE(R.allFinite()) << "case " << k;
    EXPECT_LT((R.transpose() * R - Mat2::Identity()).norm(), 1e-9) << "case " << k;
  }
  // Continuity through the degenerate threshold: shrinking one side smoothly changes R smoothly.
  Mat32 prev = Mat32::Zero();
  for (int k = 0; k <= 60; ++k) {
    const double hgt = 0.01 * std::pow(10.0, -0.2 * k);
    o.x = {Vec3(0, 0, 0), Vec3(0.01, 0, 0), Vec3(0.003, hgt, 0)};
    const Mat32 R = polar_rotation(deformation_gradient(o.x, o.tri[0], o.rest_inv[0]));
    if (k > 0) {
      EXPECT_LT((R - prev).norm(), 0.2) << "step " << k;
    }
    prev = R;
  }
}

// The integrator's shared per-triangle frame must give bit for bit what the force kernel and the separate
// F / polar helpers give, so sharing one polar decomposition does not change any simulation; checked on
// random deformed triangles and on collapsed ones (the degenerate branch).
TEST(MembraneForces, CorotatedFrameMatchesKernelBitForBit) {
  std::mt19937 rng(11);
  const MembraneParams p = paper_params();
  for (int trial = 0; trial < 200; ++trial) {
    OneTri o = random_triangle(rng, trial % 4 == 0 ? 2.0 : 0.3);
    if (trial % 50 == 7) o.x[2] = o.x[1];  // a collapsed edge: the eigenvector fallback
    std::vector<std::array<Vec3, 3>> kernel(1);
    compute_membrane_forces(o.x, o.tri, o.rest_inv, o.rest_area, p, 0, 1, kernel);
    CorotatedFrame f;
    corotated_frame(o.x[0], o.x[1], o.x[2], o.rest_inv[0], f);
    std::array<Vec3, 3> shared;
    corotated_corner_forces(f, o.rest_inv[0], o.rest_area[0], p, shared);
    const Mat32 F = deformation_gradient(o.x, o.tri[0], o.rest_inv[0]);
    EXPECT_TRUE(f.F == F) << trial;
    EXPECT_TRUE(f.R == polar_rotation(F)) << trial;
    for (int a = 0; a < 3; ++a) EXPECT_TRUE(shared[a] == kernel[0][a]) << trial << " corner " << a;
  }
}

TEST(MembraneForces, GatherIsIndependentOfRanges) {
  Sheet s = make_grid(0.2, 0.2, 12, 12, 0.3, 9);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-1, 1);
  for (Vec3& p : s.verts.x) p += 1e-3 * Vec3(u(rng), u(rng), u(rng));
  const MembraneParams params = paper_params();
  const int32_t nt = s.tris.size(), nv = s.verts.size();
  compute_membrane_forces(s.verts.x, s.tris.tri, s.tris.rest_inv, s.tris.rest_area, params, 0, nt,
                          s.tris.corner_force);
  std::vector<Vec3> a(nv), b(nv);
  gather_corner_forces(s.topo, s.tris.tri, s.tris.corner_force, 0, nv, a);
  std::vector<std::array<Vec3, 3>> cf2(nt);
  for (int32_t e = nt; e > 0; e -= 7)
    compute_membrane_forces(s.verts.x, s.tris.tri, s.tris.rest_inv, s.tris.rest_area, params, std::max(0, e - 7), e, cf2);
  for (int32_t e = nv; e > 0; e -= 5) gather_corner_forces(s.topo, s.tris.tri, cf2, std::max(0, e - 5), e, b);
  for (int32_t v = 0; v < nv; ++v) EXPECT_EQ(a[v], b[v]);
}

}  // namespace
}  // namespace pt
