// Membrane forces: constant-strain triangles with a corotated linear energy (docs/physics.md, "Membrane").
// Per triangle, F = [x1−x0, x2−x0] · rest_inv (3x2 deformation gradient), R its polar rotation (3x2,
// orthonormal columns), S = RᵀF (symmetric 2x2 stretch), E = S − I with principal strains ε₁ ≥ ε₂, energy
//   W = e · A · ( μ ‖F − R‖² + λ/2 · tr(E)² + μ_lim Σᵢ max(0, εᵢ − ε_lim)² )
// with plane-stress λ. μ and λ are those of the effective in-plane modulus (Material::membrane_scale of
// young); the last term stiffens a principal direction stretched past the strain limit back to paper's
// full modulus (μ_lim = μ_full − μ), so strains stay bounded while a locked coarse mesh, whose spurious
// strains are far below the limit, carries forces of paper's order. Its stress μ_lim 2 max(0, εᵢ − ε_lim)
// vᵢvᵢᵀ shares E's eigenvectors, so P = R τ with τ = ∂W/∂S holds for it as for the rest.
// With Material::compression_scale c < 1 (off by default) compressed principal directions and a
// compressed trace keep c of their stiffness up to a compression of compression_limit, past which μ_lim
// adds as for stretch (strain_limit_term computes both; docs/physics.md, "Compression relief").
// The force on each corner is −∂W/∂x_corner; each triangle writes its own three corner forces
// (Triangles::corner_force), read again by clustering (paper §5.1).
#pragma once

#include "components/sheet.hpp"

#include <span>

namespace pt {

struct MembraneParams {
  double mu = 0;       // Lamé μ of the effective in-plane modulus, Pa
  double lambda = 0;   // plane-stress λ of the effective in-plane modulus, Pa
  double thickness = 0;
  double strain_limit = 1e300;  // ε_lim: principal strain beyond which μ_lim adds
  double limit_mu = 0;          // μ_lim, Pa
  // Compression relief: a compressed principal direction (and a compressed trace) keeps the fraction
  // 1 − compression_relief of its stiffness, and the full modulus comes back (μ_lim, as past the strain
  // limit) beyond a principal strain of −compression_limit. 0: off.
  double compression_relief = 0;
  double compression_limit = 1e300;
  // The implicit step's tangent keeps at least this fraction of a compressed direction's stiffness (and of
  // λ under a compressed trace). With the relief's whole softening in it, the linear step of a finger set
  // moving against a relieved patch compressed it through the compression limit in one substep, and
  // fig12-junction's finger read 540 N after it; with a fifth kept, 0.95 N (1.02 N with the whole
  // stiffness), while the arch of bent-cylinder keeps the softer tangent's 0.25 N (0.29 N).
  double tangent_compression_floor = 0.2;
};

// The strain-limit term for a symmetric 2x2 strain E (rotated frame): returns its energy density
// μ_lim Σ max(0, εᵢ − ε_lim)² (plus the compression relief's, which is negative, when it is on) and adds its
// stress τ = ∂/∂E to `tau`; with `tangent`, also what these terms change in the linear energy's stiffness,
// with the principal directions frozen: a modulus kᵢ for each principal direction they touch, kᵢ vᵢvᵢᵀ ⊗
// vᵢvᵢᵀ (2 μ_lim past a limit; −(1 − c) 2 μ for a direction the relief softens, c = compression_scale),
// and the factor of λ's trace stiffness (c while the trace is compressed), both no softer than
// MembraneParams::tangent_compression_floor. The implicit step must see the relief's softening: with the
// stiff tangent a compressed sheet moved as if through syrup (docs/physics.md, "Compression relief").
struct StrainLimitTangent {
  int count = 0;  // ≤ 2
  Vec2 direction[2];
  double modulus[2] = {0, 0};
  double trace_scale = 1;
};
double strain_limit_term(const Mat2& strain, const MembraneParams& params, Mat2& tau,
                         StrainLimitTangent* tangent = nullptr);

// Largest principal in-plane strain max(ε₁) over triangles [begin, end) (0 if none is stretched).
double max_principal_strain(const std::vector<Vec3>& x, const std::vector<Tri>& tri,
                            const std::vector<Mat2>& rest_inv, int32_t begin, int32_t end);
MembraneParams membrane_params(const Material& m);

// Deformation gradient (3x2) of triangle t.
Eigen::Matrix<double, 3, 2> deformation_gradient(const std::vector<Vec3>& x, const Tri& tri, const Mat2& rest_inv);

// Polar rotation R (3x2, orthonormal columns) of a 3x2 F with full rank; for a degenerate F a rotation
// that is still well defined (continuous choice, no NaN).
Eigen::Matrix<double, 3, 2> polar_rotation(const Eigen::Matrix<double, 3, 2>& F);

// F, its polar rotation R and tr(RᵀF) = σ₁ + σ₂ of one triangle, and the corner forces from them. The implicit
// integrator needs forces, energy and stiffness per substep from one polar decomposition (the costly part)
// and may carry a frame over from its energy check to the next substep. The forces are bit-identical to
// what compute_membrane_forces writes for the triangle.
struct CorotatedFrame {
  Eigen::Matrix<double, 3, 2> F, R;
  double trace_s = 0;
};
void corotated_frame(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Mat2& rest_inv, CorotatedFrame& out);
void corotated_corner_forces(const CorotatedFrame& frame, const Mat2& rest_inv, double rest_area,
                             const MembraneParams& params, std::array<Vec3, 3>& corner_force);

// The energy above per unit thickness and rest area, W = μ ‖F − R‖² + λ/2 d² + the strain-limit term, with
// d = tr(RᵀF) − 2 (callers pass d as they have it), and its first Piola stress P = ∂W/∂F = 2μ (F − R) +
// λ d R + R τ_lim (R's variation is orthogonal to F − R). The energy check, the integrator and the crack driving force share them.
inline Mat2 corotated_strain(const Eigen::Matrix<double, 3, 2>& F, const Eigen::Matrix<double, 3, 2>& R) {
  const Mat2 s = R.transpose() * F;
  return 0.5 * (s + s.transpose()) - Mat2::Identity();
}
inline double corotated_energy_density(const Eigen::Matrix<double, 3, 2>& F, const Eigen::Matrix<double, 3, 2>& R,
                                       double d, const MembraneParams& params) {
  Mat2 tau = Mat2::Zero();
  return params.mu * (F - R).squaredNorm() + 0.5 * params.lambda * d * d +
         strain_limit_term(corotated_strain(F, R), params, tau);
}
inline Eigen::Matrix<double, 3, 2> corotated_stress(const Eigen::Matrix<double, 3, 2>& F,
                                                    const Eigen::Matrix<double, 3, 2>& R, double d,
                                                    const MembraneParams& params) {
  Mat2 tau = Mat2::Zero();
  strain_limit_term(corotated_strain(F, R), params, tau);
  return 2 * params.mu * (F - R) + params.lambda * d * R + R * tau;
}

// Triangles [begin, end): corner forces, written to corner_force[t]. Serial kernel; the engine calls it
// on ranges in parallel (each triangle writes only its own slot). A triangle a finger pinches
// (Triangles::pinched) is computed with pinched_params.
void compute_membrane_forces(const std::vector<Vec3>& x, const std::vector<Tri>& tri,
                             const std::vector<Mat2>& rest_inv, const std::vector<double>& rest_area,
                             std::span<const double> pinched, const MembraneParams& params, int32_t begin,
                             int32_t end, std::vector<std::array<Vec3, 3>>& corner_force);
inline void compute_membrane_forces(const std::vector<Vec3>& x, const std::vector<Tri>& tri,
                                    const std::vector<Mat2>& rest_inv, const std::vector<double>& rest_area,
                                    const MembraneParams& params, int32_t begin, int32_t end,
                                    std::vector<std::array<Vec3, 3>>& corner_force) {
  compute_membrane_forces(x, tri, rest_inv, rest_area, {}, params, begin, end, corner_force);
}

// A pinch presses the paper flat between the fingertips: it cannot wrinkle there, so the part of a
// triangle within a pinch carries compression like paper. The triangle's compressive stiffness is the
// area average, c + (1 − c)·fraction (docs/physics.md, "Compression relief"). On a trouser's leg pulled
// by a point finger, the relieved fan took the whole pull on its stretched side, reached the strain limit,
// and the finger read 1.45–1.52 N at the start on 600 triangles instead of 1.25.
inline double pinched_fraction(std::span<const double> pinched, int32_t t) {
  return t >= 0 && static_cast<size_t>(t) < pinched.size() ? pinched[t] : 0.0;
}
inline MembraneParams pinched_params(MembraneParams params, double fraction) {
  params.compression_relief *= 1 - fraction;
  return params;
}

double membrane_energy(const std::vector<Vec3>& x, const std::vector<Tri>& tri,
                       const std::vector<Mat2>& rest_inv, const std::vector<double>& rest_area,
                       const MembraneParams& params);

// Per-vertex sums in a fixed order (vertex → triangle fan, ascending), no atomics: the result does not
// depend on the thread count. Vertices [begin, end). Overwrites vertex_force[v] (bending is added after).
void gather_corner_forces(const Topology& topo, const std::vector<Tri>& tri,
                          const std::vector<std::array<Vec3, 3>>& corner_force, int32_t begin, int32_t end,
                          std::vector<Vec3>& vertex_force);

}  // namespace pt
