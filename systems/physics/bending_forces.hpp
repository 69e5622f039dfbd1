// Bending: quadratic isometric bending (Bergou et al. 2006). For a sheet that is flat at rest the energy
// is exactly quadratic, E = ½ Σ_hinges k_h ‖Σ_j K_hj x_j‖² (cotangent stencil of 4 weights per hinge),
// so its Hessian is constant: it enters the implicit step's matrix as it is.
// k_h = stiffness / (A0 + A1) (not Bergou's 3 / (A0 + A1)): calibrated so a cylindrical bend of radius r
// has the plate energy ½ D Area / r² (see bending_forces.cpp).
#pragma once

#include "components/sheet.hpp"

namespace pt {

struct BendingStencil {
  std::array<int32_t, 4> v;   // hinge vertices (Hinge::v)
  std::array<double, 4> w;    // weights, Σ w = 0; energy ½ ‖Σ w_j x_j‖² (stiffness folded into w)
};

double bending_stiffness(const Material& m);  // E e³ / (12 (1 − ν²)) · bending_scale, N·m

// One stencil per hinge from the rest pattern.
void build_bending_stencils(const std::vector<Vec2>& rest, const std::vector<Hinge>& hinges,
                            double stiffness, std::vector<BendingStencil>& stencils);

double bending_energy(const std::vector<Vec3>& x, const std::vector<BendingStencil>& stencils);

// Adds −∂E/∂x to `vertex_force` (serial; stencils in order, so deterministic).
void add_bending_forces(const std::vector<Vec3>& x, const std::vector<BendingStencil>& stencils,
                        std::vector<Vec3>& vertex_force);

}  // namespace pt
