// Corotated linear constant-strain triangles (docs/physics.md). See membrane_forces.hpp for the energy.
//
// Why this formulation: for the corotated energy W(F) = e·A·(μ‖F − R‖² + λ/2 tr(RᵀF − I)²) with R the polar
// factor of F, the first Piola stress has the closed form P = e·A·(2μ(F − R) + λ tr(RᵀF − I) R): the terms
// in dR vanish because RᵀdR is skew and RᵀF = S is symmetric (McAdams et al. 2011, "Efficient elasticity for
// character skinning with contact and collisions", §4; the same identity holds for a 3x2 F since
// tr(RᵀF) = σ₁ + σ₂ and ∂(σ₁ + σ₂)/∂F = U Vᵀ = R).
//
// Polar factor of a 3x2 F: with C = FᵀF (2x2, SPD when F has full rank), S = √C and R = F S⁻¹. The 2x2
// square root has a closed form (Cayley–Hamilton): √C = (C + √det C · I) / √(tr C + 2 √det C), and
// √(tr C + 2 √det C) = σ₁ + σ₂ = tr S. So the fast path needs two square roots and one division.
#include "systems/physics/membrane_forces.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

namespace pt {

namespace {

using Mat32 = Eigen::Matrix<double, 3, 2>;

// Below this ratio det C / (tr C)² ≈ (σ₂/σ₁)² the closed form loses accuracy (R = F S⁻¹ divides by σ₁σ₂);
// the eigenvector fallback is used instead. 1e-10 ⇔ σ₂/σ₁ ≈ 1e-5.
constexpr double kDegenerateRatio = 1e-10;

// Polar factor of a (nearly) rank-deficient F from the eigenvectors of C: R = u₁v₁ᵀ + u₂v₂ᵀ. Continuous with
// the fast path while F has numerically full rank (u₂ = normalised F v₂ with its u₁ part removed); when F v₂
// vanishes u₂ is chosen perpendicular to u₁, preferably in the plane z = const (the sheet starts flat in
// z = 0, so a collapsed triangle of a flat sheet keeps a rotation in that plane). Never NaN.
Mat32 polar_rotation_degenerate(const Mat32& F) {
  const double p = F.col(0).squaredNorm(), q = F.col(0).dot(F.col(1)), r = F.col(1).squaredNorm();
  const double scale = p + r;
  Mat32 R;
  if (!(scale > 1e-300)) {  // F ≈ 0 (triangle collapsed to a point) or not finite: the rest frame.
    R << 1, 0, 0, 1, 0, 0;
    return R;
  }
  // Largest eigenvalue of C and its eigenvector (the better conditioned of the two formulas).
  const double half_diff = 0.5 * (p - r);
  const double l1 = 0.5 * (p + r) + std::sqrt(half_diff * half_diff + q * q);
  Vec2 v1 = p >= r ? Vec2(l1 - r, q) : Vec2(q, l1 - p);
  const double v1n = v1.norm();
  v1 = v1n > 0 ? Vec2(v1 / v1n) : Vec2(1, 0);
  const Vec2 v2(-v1.y(), v1.x());
  Vec3 u1 = F * v1;
  u1 /= u1.norm();  // ‖F v₁‖ = σ₁ > 0 since scale > 0
  Vec3 w = F * v2;
  w -= u1.dot(w) * u1;
  const double wn = w.norm();
  Vec3 u2;
  if (wn > 1e-14 * std::sqrt(l1)) {
    u2 = w / wn;
  } else {
    Vec3 c = Vec3::UnitZ().cross(u1);  // in-plane perpendicular for a flat sheet
    if (c.squaredNorm() < 1e-6) c = Vec3::UnitX().cross(u1);
    u2 = c.normalized();
  }
  R = u1 * v1.transpose() + u2 * v2.transpose();
  return R;
}

}  // namespace

MembraneParams membrane_params(const Material& m) {
  MembraneParams p;
  const double young = m.young * m.membrane_scale;
  p.mu = young / (2 * (1 + m.poisson));
  const double lambda0 = young * m.poisson / ((1 + m.poisson) * (1 - 2 * m.poisson));
  // Plane stress: eliminating σ_zz = 0 gives λ = 2μλ₀/(λ₀ + 2μ) = Eν/(1 − ν²).
  p.lambda = 2 * p.mu * lambda0 / (lambda0 + 2 * p.mu);
  p.thickness = m.thickness;
  p.strain_limit = m.strain_limit;
  p.limit_mu = std::max(0.0, m.young / (2 * (1 + m.poisson)) - p.mu);
  p.compression_relief = 1 - m.compression_scale;
  p.compression_limit = m.compression_limit;
  return p;
}

namespace {

// Unit eigenvector of the larger principal strain (the better conditioned of the two formulas).
Vec2 first_eigenvector(double h, double b, double r) {
  Vec2 v1 = h >= 0 ? Vec2(r + h, b) : Vec2(b, r - h);
  const double n = v1.norm();
  return n > 1e-300 ? Vec2(v1 / n) : Vec2(1, 0);
}

// Past the strain limit: μ_lim Σ max(0, εᵢ − ε_lim)², its stress and tangent. m ± r are the principal strains.
double stretch_limit_term(double m, double h, double b, double r, const MembraneParams& params, Mat2& tau,
                          StrainLimitTangent* tangent) {
  const double limit = params.strain_limit;
  if (!(m + r > limit) || !(params.limit_mu > 0)) return 0;  // the common case: nothing stretched past the limit
  const double x1 = m + r - limit, x2 = std::max(0.0, m - r - limit);
  const Vec2 v1 = first_eigenvector(h, b, r), v2(-v1.y(), v1.x());
  const double k = 2 * params.limit_mu;
  tau += k * x1 * (v1 * v1.transpose()) + k * x2 * (v2 * v2.transpose());
  if (tangent) {
    tangent->count = 0;
    tangent->direction[tangent->count] = v1;
    tangent->modulus[tangent->count++] = k;
    if (x2 > 0) {
      tangent->direction[tangent->count] = v2;
      tangent->modulus[tangent->count++] = k;
    }
  }
  return params.limit_mu * (x1 * x1 + x2 * x2);
}

// The relief: with c = 1 − compression_relief, W = μ Σ g(εᵢ) + λ/2 g(ε₁ + ε₂) for g(x) = x² (x ≥ 0),
// c x² (x < 0): each term stays convex and C¹. This returns its difference from the linear energy,
// −(1 − c) (μ Σ min(0, εᵢ)² + λ/2 min(0, ε₁ + ε₂)²), plus μ_lim max(0, −εᵢ − limit)², and adds its stress
// Σ σᵢ vᵢvᵢᵀ (a symmetric function of the eigenvalues) to tau.
double compression_relief_term(double m, double h, double b, double r, const MembraneParams& params, Mat2& tau,
                               StrainLimitTangent* tangent) {
  const double e[2] = {m + r, m - r};
  const double relief = params.compression_relief, mu = params.mu, lambda = params.lambda;
  const double trace = std::min(0.0, e[0] + e[1]);
  double energy = -relief * 0.5 * lambda * trace * trace;
  double sigma[2], past_limit[2];
  for (int i = 0; i < 2; ++i) {
    const double c = std::min(0.0, e[i]), x = std::max(0.0, -e[i] - params.compression_limit);
    energy += -relief * mu * c * c + params.limit_mu * x * x;
    sigma[i] = -relief * (2 * mu * c + lambda * trace) - 2 * params.limit_mu * x;
    past_limit[i] = x;
  }
  const Vec2 v1 = first_eigenvector(h, b, r), v2(-v1.y(), v1.x());
  tau += sigma[0] * (v1 * v1.transpose()) + sigma[1] * (v2 * v2.transpose());
  // The tangent: a compressed direction keeps c of 2μ (at least tangent_compression_floor of it), and past
  // the compression limit the full modulus is back, as past the stretch limit. (No direction is both
  // compressed here and stretched past the limit, so the stretch term has left these slots free.)
  if (tangent) {
    const double trelief = std::min(relief, 1 - params.tangent_compression_floor);
    if (trace < 0) tangent->trace_scale = 1 - trelief;
    for (int i = 0; i < 2; ++i)
      if (e[i] < 0 && tangent->count < 2) {
        tangent->direction[tangent->count] = i == 0 ? v1 : v2;
        tangent->modulus[tangent->count++] = -trelief * 2 * mu + 2 * params.limit_mu * (past_limit[i] > 0);
      }
  }
  return energy;
}

}  // namespace

double strain_limit_term(const Mat2& strain, const MembraneParams& params, Mat2& tau, StrainLimitTangent* tangent) {
  const double a = strain(0, 0), c = strain(1, 1), b = 0.5 * (strain(0, 1) + strain(1, 0));
  const double m = 0.5 * (a + c), h = 0.5 * (a - c);
  const double r = std::sqrt(h * h + b * b);
  const double stretched = stretch_limit_term(m, h, b, r, params, tau, tangent);
  if (params.compression_relief > 0 && m - r < 0) return stretched + compression_relief_term(m, h, b, r, params, tau, tangent);
  return stretched;
}

double max_principal_strain(const std::vector<Vec3>& x, const std::vector<Tri>& tri,
                            const std::vector<Mat2>& rest_inv, int32_t begin, int32_t end) {
  double largest = 0;
  for (int32_t t = begin; t < end; ++t) {
    const Mat32 F = deformation_gradient(x, tri[t], rest_inv[t]);
    const Mat2 e = corotated_strain(F, polar_rotation(F));
    const double m = 0.5 * (e(0, 0) + e(1, 1)), h = 0.5 * (e(0, 0) - e(1, 1)), b = 0.5 * (e(0, 1) + e(1, 0));
    const double e1 = m + std::sqrt(h * h + b * b);
    if (e1 > largest) largest = e1;  // NaN never compares greater
  }
  return largest;
}

Eigen::Matrix<double, 3, 2> deformation_gradient(const std::vector<Vec3>& x, const Tri& tri, const Mat2& rest_inv) {
  Mat32 Ds;
  Ds.col(0) = x[tri[1]] - x[tri[0]];
  Ds.col(1) = x[tri[2]] - x[tri[0]];
  return Ds * rest_inv;
}

Eigen::Matrix<double, 3, 2> polar_rotation(const Eigen::Matrix<double, 3, 2>& F) {
  const double p = F.col(0).squaredNorm(), q = F.col(0).dot(F.col(1)), r = F.col(1).squaredNorm();
  const double trC = p + r, detC = p * r - q * q;
  if (!(detC > kDegenerateRatio * trC * trC)) return polar_rotation_degenerate(F);
  const double s = std::sqrt(detC);         // σ₁σ₂ = det S
  const double t = std::sqrt(trC + 2 * s);  // σ₁ + σ₂ = tr S
  const double k = 1.0 / (t * s);
  // S⁻¹ = adj(C + sI) / (t s)
  Mat32 R;
  R.col(0) = ((r + s) * k) * F.col(0) - (q * k) * F.col(1);
  R.col(1) = ((p + s) * k) * F.col(1) - (q * k) * F.col(0);
  return R;
}

// The kernel: plain scalar code on the three columns so the compiler keeps everything in registers
// (no Eigen temporaries, no allocation). ~40 multiplies, two sqrt, one division per triangle. Split in two
// inline halves (F and R; then the forces) so the implicit integrator can share one polar decomposition
// between forces, energy and stiffness with bit-identical results.
namespace {

struct CorotatedScalars {
  double ax, ay, az, bx, by, bz;        // F, columns a and b
  double rax, ray, raz, rbx, rby, rbz;  // R, columns a and b
  double trS;                           // tr(RᵀF) = σ₁ + σ₂
};

inline CorotatedScalars corotated_scalars(const double* x0, const double* x1, const double* x2, const Mat2& B) {
  CorotatedScalars o;
  const double d1x = x1[0] - x0[0], d1y = x1[1] - x0[1], d1z = x1[2] - x0[2];
  const double d2x = x2[0] - x0[0], d2y = x2[1] - x0[1], d2z = x2[2] - x0[2];
  const double b00 = B(0, 0), b01 = B(0, 1), b10 = B(1, 0), b11 = B(1, 1);
  // F = Ds · B, columns a and b.
  const double ax = d1x * b00 + d2x * b10, ay = d1y * b00 + d2y * b10, az = d1z * b00 + d2z * b10;
  const double bx = d1x * b01 + d2x * b11, by = d1y * b01 + d2y * b11, bz = d1z * b01 + d2z * b11;
  o.ax = ax; o.ay = ay; o.az = az; o.bx = bx; o.by = by; o.bz = bz;
  const double p = ax * ax + ay * ay + az * az;
  const double q = ax * bx + ay * by + az * bz;
  const double r = bx * bx + by * by + bz * bz;
  const double trC = p + r, detC = p * r - q * q;
  if (detC > kDegenerateRatio * trC * trC) {
    const double s = std::sqrt(detC);
    o.trS = std::sqrt(trC + 2 * s);
    const double k = 1.0 / (o.trS * s);
    const double c00 = (r + s) * k, c11 = (p + s) * k, c01 = q * k;
    o.rax = c00 * ax - c01 * bx; o.ray = c00 * ay - c01 * by; o.raz = c00 * az - c01 * bz;
    o.rbx = c11 * bx - c01 * ax; o.rby = c11 * by - c01 * ay; o.rbz = c11 * bz - c01 * az;
  } else {
    Mat32 F;
    F << ax, bx, ay, by, az, bz;
    const Mat32 R = polar_rotation_degenerate(F);
    o.rax = R(0, 0); o.ray = R(1, 0); o.raz = R(2, 0);
    o.rbx = R(0, 1); o.rby = R(1, 1); o.rbz = R(2, 1);
    o.trS = o.rax * ax + o.ray * ay + o.raz * az + o.rbx * bx + o.rby * by + o.rbz * bz;
  }
  return o;
}

// P = e A (2μ (F − R) + λ (tr S − 2) R); the corner forces are H = −P Bᵀ on corners 1 and 2, corner 0
// balances them (translation invariance).
inline void corner_forces_of(double ax, double ay, double az, double bx, double by, double bz, double rax,
                             double ray, double raz, double rbx, double rby, double rbz, double trS, const Mat2& B,
                             double eA, double two_mu, double lambda, const MembraneParams* limit,
                             std::array<Vec3, 3>& out) {
  const double b00 = B(0, 0), b01 = B(0, 1), b10 = B(1, 0), b11 = B(1, 1);
  const double m = eA * two_mu, l = eA * lambda * (trS - 2) - m;
  double pax = m * ax + l * rax, pay = m * ay + l * ray, paz = m * az + l * raz;
  double pbx = m * bx + l * rbx, pby = m * by + l * rby, pbz = m * bz + l * rbz;
  if (limit != nullptr) {
    // The strain-limit stress P += R τ, with E = sym(RᵀF) − I.
    Mat2 strain;
    const double s01 = 0.5 * (rax * bx + ray * by + raz * bz + rbx * ax + rby * ay + rbz * az);
    strain << rax * ax + ray * ay + raz * az - 1, s01, s01, rbx * bx + rby * by + rbz * bz - 1;
    Mat2 tau = Mat2::Zero();
    if (strain_limit_term(strain, *limit, tau) != 0) {
      const double t00 = eA * tau(0, 0), t01 = eA * tau(0, 1), t11 = eA * tau(1, 1);
      pax += rax * t00 + rbx * t01, pay += ray * t00 + rby * t01, paz += raz * t00 + rbz * t01;
      pbx += rax * t01 + rbx * t11, pby += ray * t01 + rby * t11, pbz += raz * t01 + rbz * t11;
    }
  }
  const double f1x = -(pax * b00 + pbx * b01), f1y = -(pay * b00 + pby * b01), f1z = -(paz * b00 + pbz * b01);
  const double f2x = -(pax * b10 + pbx * b11), f2y = -(pay * b10 + pby * b11), f2z = -(paz * b10 + pbz * b11);
  out[0] = Vec3(-(f1x + f2x), -(f1y + f2y), -(f1z + f2z));
  out[1] = Vec3(f1x, f1y, f1z);
  out[2] = Vec3(f2x, f2y, f2z);
}

}  // namespace

void corotated_frame(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Mat2& rest_inv, CorotatedFrame& out) {
  const CorotatedScalars c = corotated_scalars(x0.data(), x1.data(), x2.data(), rest_inv);
  out.F << c.ax, c.bx, c.ay, c.by, c.az, c.bz;
  out.R << c.rax, c.rbx, c.ray, c.rby, c.raz, c.rbz;
  out.trace_s = c.trS;
}

void corotated_corner_forces(const CorotatedFrame& f, const Mat2& rest_inv, double rest_area,
                             const MembraneParams& params, std::array<Vec3, 3>& corner_force) {
  const Mat32& F = f.F;
  const Mat32& R = f.R;
  corner_forces_of(F(0, 0), F(1, 0), F(2, 0), F(0, 1), F(1, 1), F(2, 1), R(0, 0), R(1, 0), R(2, 0), R(0, 1), R(1, 1),
                   R(2, 1), f.trace_s, rest_inv, params.thickness * rest_area, 2 * params.mu, params.lambda,
                   params.limit_mu > 0 || params.compression_relief > 0 ? &params : nullptr, corner_force);
}

void compute_membrane_forces(const std::vector<Vec3>& x, const std::vector<Tri>& tri,
                             const std::vector<Mat2>& rest_inv, const std::vector<double>& rest_area,
                             std::span<const double> pinched, const MembraneParams& params, int32_t begin,
                             int32_t end, std::vector<std::array<Vec3, 3>>& corner_force) {
  const double two_mu = 2 * params.mu, lambda = params.lambda, e = params.thickness;
  const MembraneParams* limit = params.limit_mu > 0 || params.compression_relief > 0 ? &params : nullptr;
  MembraneParams pinched_own;
  for (int32_t t = begin; t < end; ++t) {
    const Tri& c = tri[t];
    const CorotatedScalars s = corotated_scalars(x[c[0]].data(), x[c[1]].data(), x[c[2]].data(), rest_inv[t]);
    // A pinched triangle's own parameters, built only for the few a finger holds (Triangles::pinched).
    const double fraction = pinched_fraction(pinched, t);
    if (fraction > 0) pinched_own = pinched_params(params, fraction);
    const MembraneParams* own_limit = fraction > 0 ? &pinched_own : limit;
    corner_forces_of(s.ax, s.ay, s.az, s.bx, s.by, s.bz, s.rax, s.ray, s.raz, s.rbx, s.rby, s.rbz, s.trS, rest_inv[t],
                     e * rest_area[t], two_mu, lambda, own_limit, corner_force[t]);
  }
}

double membrane_energy(const std::vector<Vec3>& x, const std::vector<Tri>& tri,
                       const std::vector<Mat2>& rest_inv, const std::vector<double>& rest_area,
                       const MembraneParams& params) {
  double total = 0;
  for (size_t t = 0; t < tri.size(); ++t) {
    const Mat32 F = deformation_gradient(x, tri[t], rest_inv[t]);
    const Mat32 R = polar_rotation(F);
    const double tr = (R.transpose() * F).trace() - 2;
    total += params.thickness * rest_area[t] * corotated_energy_density(F, R, tr, params);
  }
  return total;
}

void gather_corner_forces(const Topology& topo, const std::vector<Tri>& tri,
                          const std::vector<std::array<Vec3, 3>>& corner_force, int32_t begin, int32_t end,
                          std::vector<Vec3>& vertex_force) {
  for (int32_t v = begin; v < end; ++v) {
    Vec3 sum = Vec3::Zero();
    for (const int32_t t : topo.fan(v)) {
      const Tri& c = tri[t];
      const int32_t i = c[0] == v ? 0 : (c[1] == v ? 1 : 2);
      sum += corner_force[t][i];
    }
    vertex_force[v] = sum;
  }
}

}  // namespace pt
