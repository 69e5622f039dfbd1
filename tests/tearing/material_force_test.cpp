// The crack driving force (systems/tearing/material_force.hpp) against independent truths: the energy released
// by a virtual advance of the tip, computed by finite differences of the membrane energy with the rest
// positions moved (the definition of J); zero in an intact, uniformly strained sheet; equivariance under
// a rigid rotation of pattern and sheet; the domain and its cap.
#include "systems/tearing/material_force.hpp"

#include "engine/scenario.hpp"
#include "engine/sheet_builder.hpp"
#include "systems/physics/membrane_forces.hpp"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>

using namespace pt;

namespace {

// A 12 x 10 cm sheet with a V notch in its top edge, apex at (0.06, 0.07).
Sheet notched_sheet(int32_t triangles = 200) {
  Scenario s;
  s.outline = {Vec2(0, 0), Vec2(0.12, 0), Vec2(0.12, 0.1), Vec2(0.064, 0.1), Vec2(0.06, 0.07), Vec2(0.056, 0.1),
               Vec2(0, 0.1)};
  s.triangles = triangles;
  return build_sheet(s);
}

int32_t nearest_vertex(const Sheet& s, const Vec2& uv) {
  int32_t best = 0;
  for (int32_t v = 1; v < s.verts.size(); ++v)
    if ((s.verts.rest[v] - uv).norm() < (s.verts.rest[best] - uv).norm()) best = v;
  return best;
}

// A smooth, non-homogeneous deformation: the notch opened (u stretched more near the top), the sheet
// curled out of plane and rotated.
void deform(Sheet& s) {
  for (int32_t v = 0; v < s.verts.size(); ++v) {
    const double u = s.verts.rest[v].x() - 0.06, w = s.verts.rest[v].y();
    const Vec3 p(u * (1 + 0.004 + 0.02 * w), w * (1 - 0.001) + 0.003 * u * u, 0.2 * u * u + 0.05 * u * w);
    s.verts.x[v] = Eigen::AngleAxisd(0.3, Vec3(0.2, 1, 0.5).normalized()) * p;
  }
}

// Membrane energy per unit thickness with the rest positions `rest` (rest data recomputed here, not by
// the engine's topology code).
double membrane_energy_with_rest(const Sheet& s, const std::vector<Vec2>& rest, const MembraneParams& mp) {
  std::vector<Mat2> rest_inv(s.tris.size());
  std::vector<double> area(s.tris.size());
  for (int32_t t = 0; t < s.tris.size(); ++t) {
    const Tri& c = s.tris.tri[t];
    Mat2 d;
    d.col(0) = rest[c[1]] - rest[c[0]];
    d.col(1) = rest[c[2]] - rest[c[0]];
    rest_inv[t] = d.inverse();
    area[t] = 0.5 * d.determinant();
  }
  return membrane_energy(s.verts.x, s.tris.tri, rest_inv, area, mp) / mp.thickness;
}

MembraneParams paper() { return membrane_params(Material{}); }

}  // namespace

// J·e = −dΠ/da: move every rest position by a q(X) e (q = 1 at p, 0 at the radius), keep x, and take the
// energy's derivative by central differences.
TEST(MaterialForce, EqualsTheEnergyReleasedByAVirtualAdvance) {
  Sheet s = notched_sheet();
  deform(s);
  const MembraneParams mp = paper();
  const int32_t p = nearest_vertex(s, Vec2(0.06, 0.07));
  ASSERT_LT((s.verts.rest[p] - Vec2(0.06, 0.07)).norm(), 1e-9);
  const double radius = 0.03;
  DrivingForceScratch scratch;
  const DrivingForce f = crack_driving_force(s.verts, s.tris, s.topo, p, radius, mp, scratch);
  ASSERT_GT(f.triangles, 10);
  ASSERT_GT(f.j.norm(), 0);
  for (const Vec2& e : {Vec2(1, 0), Vec2(0, 1), Vec2(0.6, -0.8)}) {
    const double h = 1e-7;
    auto energy = [&](double a) {
      std::vector<Vec2> rest = s.verts.rest;
      for (int32_t v = 0; v < s.verts.size(); ++v) {
        const double q = v == p ? 1.0 : std::max(0.0, 1.0 - (s.verts.rest[v] - s.verts.rest[p]).norm() / radius);
        rest[v] += a * q * e;
      }
      return membrane_energy_with_rest(s, rest, mp);
    };
    const double released = -(energy(h) - energy(-h)) / (2 * h);
    EXPECT_NEAR(f.j.dot(e), released, 1e-5 * f.j.norm()) << "e = " << e.transpose();
  }
}

// An interior vertex of an intact sheet under a homogeneous deformation: Σ is the same on every triangle
// and Σ_t A_t ∇q_t = 0, so nothing drives it (J is zero up to rounding).
TEST(MaterialForce, VanishesInAnIntactUniformlyStrainedSheet) {
  Scenario sc;
  sc.outline = {Vec2(0, 0), Vec2(0.2, 0), Vec2(0.2, 0.2), Vec2(0, 0.2)};
  sc.triangles = 400;
  Sheet s = build_sheet(sc);
  Eigen::Matrix<double, 3, 2> F;
  F << 1.003, 0.001, 0.0005, 0.998, 0.02, -0.01;
  for (int32_t v = 0; v < s.verts.size(); ++v) s.verts.x[v] = F * s.verts.rest[v];
  const MembraneParams mp = paper();
  const int32_t p = nearest_vertex(s, Vec2(0.1, 0.1));
  DrivingForceScratch scratch;
  const DrivingForce f = crack_driving_force(s.verts, s.tris, s.topo, p, 0.05, mp, scratch);
  ASSERT_GT(f.triangles, 20);
  // Scale: W · r, the size of one triangle's term.
  CorotatedFrame frame;
  const Tri& t0 = s.tris.tri[0];
  corotated_frame(s.verts.x[t0[0]], s.verts.x[t0[1]], s.verts.x[t0[2]], s.tris.rest_inv[0], frame);
  const double w = mp.mu * (frame.F - frame.R).squaredNorm();
  ASSERT_GT(w, 0);
  EXPECT_LT(f.j.norm(), 1e-9 * w * 0.05);
}

// Turning pattern and sheet by the same rigid rotation about z turns J with them.
TEST(MaterialForce, TurnsWithTheSheet) {
  Sheet s = notched_sheet();
  deform(s);
  const MembraneParams mp = paper();
  const int32_t p = nearest_vertex(s, Vec2(0.06, 0.07));
  DrivingForceScratch scratch;
  const Vec2 j = crack_driving_force(s.verts, s.tris, s.topo, p, 0.03, mp, scratch).j;
  const double angle = 0.7;
  const Mat2 turn2 = Eigen::Rotation2Dd(angle).toRotationMatrix();
  const Eigen::Matrix3d turn3 = Eigen::AngleAxisd(angle, Vec3::UnitZ()).toRotationMatrix();
  Sheet r = s;
  for (int32_t v = 0; v < r.verts.size(); ++v) {
    r.verts.rest[v] = turn2 * s.verts.rest[v];
    r.verts.x[v] = turn3 * s.verts.x[v];
  }
  for (int32_t t = 0; t < r.tris.size(); ++t) r.tris.rest_inv[t] = s.tris.rest_inv[t] * turn2.transpose();
  const Vec2 jr = crack_driving_force(r.verts, r.tris, r.topo, p, 0.03, mp, scratch).j;
  EXPECT_NEAR((jr - turn2 * j).norm(), 0, 1e-9 * j.norm());
}

// The domain: a radius capped by the nearest other singular vertex; a zero or negative radius, or a
// vertex out of range, gives no force.
TEST(MaterialForce, DomainRadiusAndDegenerateInput) {
  Sheet s = notched_sheet();
  deform(s);
  const int32_t p = nearest_vertex(s, Vec2(0.06, 0.07));
  const int32_t q = nearest_vertex(s, Vec2(0.03, 0.05));
  const double d = (s.verts.rest[q] - s.verts.rest[p]).norm();
  EXPECT_EQ(domain_radius(s.verts.rest, p, {q, -1, p}, 1.0), d);
  EXPECT_EQ(domain_radius(s.verts.rest, p, {}, 0.04), 0.04);
  DrivingForceScratch scratch;
  const MembraneParams mp = paper();
  EXPECT_EQ(crack_driving_force(s.verts, s.tris, s.topo, p, 0.0, mp, scratch).j, Vec2::Zero());
  EXPECT_EQ(crack_driving_force(s.verts, s.tris, s.topo, -1, 0.03, mp, scratch).j, Vec2::Zero());
  EXPECT_EQ(crack_driving_force(s.verts, s.tris, s.topo, s.verts.size(), 0.03, mp, scratch).j, Vec2::Zero());
  // A tiny radius: the domain is p's own fan.
  const DrivingForce fan = crack_driving_force(s.verts, s.tris, s.topo, p, 1e-9, mp, scratch);
  EXPECT_EQ(fan.triangles, static_cast<int32_t>(s.topo.fan(p).size()));
}
