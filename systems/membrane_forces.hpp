// Membrane forces: constant-strain triangles with a corotated linear energy (DESIGN §4).
// Per triangle, F = [x1−x0, x2−x0] · rest_inv (3x2 deformation gradient), R its polar rotation (3x2,
// orthonormal columns), energy  W = e · A · ( μ ‖F − R‖² + λ/2 · tr(RᵀF − I)² )  with plane-stress λ.
// The force on each corner is −∂W/∂x_corner; each triangle writes its own three corner forces
// (Triangles::corner_force), read again by clustering (paper §5.1).
#pragma once

#include "components/sheet.hpp"

namespace pt {

struct MembraneParams {
  double mu = 0;       // Lamé μ, Pa
  double lambda = 0;   // plane-stress λ, Pa
  double thickness = 0;
};
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

// The energy above per unit thickness and rest area, W = μ ‖F − R‖² + λ/2 d² with d = tr(RᵀF) − 2 (callers
// pass d as they have it), and its first Piola stress P = ∂W/∂F = 2μ (F − R) + λ d R (R's variation is
// orthogonal to F − R). The energy check, the integrator and the crack driving force share them.
inline double corotated_energy_density(const Eigen::Matrix<double, 3, 2>& F, const Eigen::Matrix<double, 3, 2>& R,
                                       double d, const MembraneParams& params) {
  return params.mu * (F - R).squaredNorm() + 0.5 * params.lambda * d * d;
}
inline Eigen::Matrix<double, 3, 2> corotated_stress(const Eigen::Matrix<double, 3, 2>& F,
                                                    const Eigen::Matrix<double, 3, 2>& R, double d,
                                                    const MembraneParams& params) {
  return 2 * params.mu * (F - R) + params.lambda * d * R;
}

// Triangles [begin, end): corner forces, written to corner_force[t]. Serial kernel; the engine calls it
// on ranges in parallel (each triangle writes only its own slot).
void compute_membrane_forces(const std::vector<Vec3>& x, const std::vector<Tri>& tri,
                             const std::vector<Mat2>& rest_inv, const std::vector<double>& rest_area,
                             const MembraneParams& params, int32_t begin, int32_t end,
                             std::vector<std::array<Vec3, 3>>& corner_force);

double membrane_energy(const std::vector<Vec3>& x, const std::vector<Tri>& tri,
                       const std::vector<Mat2>& rest_inv, const std::vector<double>& rest_area,
                       const MembraneParams& params);

// Per-vertex sums in a fixed order (vertex → triangle fan, ascending), no atomics: the result does not
// depend on the thread count. Vertices [begin, end). Overwrites vertex_force[v] (bending is added after).
void gather_corner_forces(const Topology& topo, const std::vector<Tri>& tri,
                          const std::vector<std::array<Vec3, 3>>& corner_force, int32_t begin, int32_t end,
                          std::vector<Vec3>& vertex_force);

}  // namespace pt
