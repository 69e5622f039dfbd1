// Quadratic isometric bending (Bergou, Wardetzky, Harmon, Zorin, Grinspun 2006, "A quadratic bending model
// for inextensible surfaces", §4). See bending_forces.hpp.
//
// Hinge (v0, v1 | v2, v3): triangle A = (v0, v1, v2) is counter-clockwise, triangle B = (v1, v0, v3).
// With α0, α1 the angles of A at v0, v1 and β0, β1 those of B, the hinge Laplacian is
//     K = ( cot α1 + cot β1,  cot α0 + cot β0,  −cot α0 − cot α1,  −cot β0 − cot β1 )
// (Bergou's K = (c03 + c04, c01 + c02, −c01 − c03, −c02 − c04) with c_jk the cotangent of the angle between
// edges e_j and e_k, e0 = x1 − x0, e1 = x2 − x0, e2 = x3 − x0, e3 = x2 − x1, e4 = x3 − x1).
// Why it works: cot α1 x0 + cot α0 x1 = (cot α0 + cot α1) · foot of the altitude from x2, so the A part of
// K·x is −|e| n̂_A (n̂_A: unit in-surface normal of the edge pointing into A) and K·x = −|e| (n̂_A + n̂_B): zero
// for any flat (affine) placement of the hinge, |e| θ for a dihedral angle θ.
//
// Normalisation: Bergou's Q = 3/(A0 + A1) K Kᵀ is the discrete-shells constant (Grinspun et al. 2003: the
// curvature across an edge taken as θ over a third of the hinge height). Measured on a cylinder of radius r
// it gives 3× the plate energy ½ D ∫κ² dA = ½ D Area / r² (near-equilateral meshes, any axis direction; and
// exactly 3× on a right-triangle grid bent across one edge family: per cell ½·3k·a²/r² vs ½k·a²/r²). We use
// 1/(A0 + A1) so `bending_stiffness` (E e³ / 12(1 − ν²)) means what plate theory says: the cylinder test in
// tests/physics/bending_forces_test.cpp gives 0.97–1.02 on equilateral grids, up to 1.07 with 20% jitter, 1.19 with
// 30%; the right-triangle grid ranges 0.97 (bent across an edge family) to 1.49 (bent along a diagonal).
#include "systems/physics/bending_forces.hpp"

#include <cmath>

namespace pt {

namespace {

// See the header comment: 3 is Bergou's constant, 1 calibrates a cylinder bend to plate theory.
constexpr double kBergouNormalisation = 1.0;

// cot of the angle at `a` in the pattern triangle (a, b, c) and twice its area (unsigned).
inline double cot_at(const Vec2& a, const Vec2& b, const Vec2& c) {
  const Vec2 u = b - a, v = c - a;
  const double cross = std::abs(u.x() * v.y() - u.y() * v.x());
  return cross > 0 ? u.dot(v) / cross : 0.0;
}

inline double area2(const Vec2& a, const Vec2& b, const Vec2& c) {
  const Vec2 u = b - a, v = c - a;
  return std::abs(u.x() * v.y() - u.y() * v.x());
}

}  // namespace

double bending_stiffness(const Material& m) {
  const double e = m.thickness;
  return m.young * e * e * e / (12 * (1 - m.poisson * m.poisson)) * m.bending_scale;
}

void build_bending_stencils(const std::vector<Vec2>& rest, const std::vector<Hinge>& hinges,
                            double stiffness, std::vector<BendingStencil>& stencils) {
  stencils.resize(hinges.size());
  for (size_t h = 0; h < hinges.size(); ++h) {
    const auto& v = hinges[h].v;
    const Vec2 &x0 = rest[v[0]], &x1 = rest[v[1]], &x2 = rest[v[2]], &x3 = rest[v[3]];
    const double area_sum = 0.5 * (area2(x0, x1, x2) + area2(x0, x1, x3));
    BendingStencil& s = stencils[h];
    s.v = v;
    if (!(area_sum > 0) || !(stiffness > 0)) {  // degenerate pattern hinge: no bending (never NaN)
      s.w = {0, 0, 0, 0};
      continue;
    }
    const double ca0 = cot_at(x0, x1, x2), ca1 = cot_at(x1, x0, x2);
    const double cb0 = cot_at(x0, x1, x3), cb1 = cot_at(x1, x0, x3);
    const double scale = std::sqrt(kBergouNormalisation * stiffness / area_sum);
    s.w = {scale * (ca1 + cb1), scale * (ca0 + cb0), -scale * (ca0 + ca1), -scale * (cb0 + cb1)};
  }
}

double bending_energy(const std::vector<Vec3>& x, const std::vector<BendingStencil>& stencils) {
  double total = 0;
  for (const BendingStencil& s : stencils) {
    const Vec3 k = s.w[0] * x[s.v[0]] + s.w[1] * x[s.v[1]] + s.w[2] * x[s.v[2]] + s.w[3] * x[s.v[3]];
    total += 0.5 * k.squaredNorm();
  }
  return total;
}

void add_bending_forces(const std::vector<Vec3>& x, const std::vector<BendingStencil>& stencils,
                        std::vector<Vec3>& vertex_force) {
  for (const BendingStencil& s : stencils) {
    const Vec3 k = s.w[0] * x[s.v[0]] + s.w[1] * x[s.v[1]] + s.w[2] * x[s.v[2]] + s.w[3] * x[s.v[3]];
    for (int j = 0; j < 4; ++j) vertex_force[s.v[j]] -= s.w[j] * k;
  }
}

}  // namespace pt
