// Implicit integration by projective dynamics (Bouaziz et al. 2014): backward Euler solved by local
// (per-triangle polar rotation) / global (prefactored sparse Cholesky) iterations. The factorisation is
// reused until the topology or the set of held vertices changes. Finger vertices are prescribed: they
// are eliminated from the system and follow their targets.
#pragma once

#include "components/sheet.hpp"
#include "systems/bending_forces.hpp"
#include "systems/membrane_forces.hpp"
#include "systems/parallel.hpp"

#include <memory>

namespace pt {

struct IntegrateParams {
  double dt = 1.0 / 300;          // substep, s
  Vec3 gravity = Vec3(0, 0, -9.81);
  int32_t iterations = 2;         // local/global iterations per substep
  double damping = 2.0;           // 1/s
  RangeRunner run = run_serial;   // parallel loops over triangles / vertices (engine supplies oneTBB)
  int32_t grain = 512;
};

// Opaque solver state (factorisation, scratch). One per sheet.
struct ProjectiveSolver;
struct ProjectiveSolverDeleter {
  void operator()(ProjectiveSolver*) const;
};
using ProjectiveSolverPtr = std::unique_ptr<ProjectiveSolver, ProjectiveSolverDeleter>;

// (Re)builds the solver when the sheet's topology_version, the held vertices or dt changed since the last
// call; otherwise returns the existing one untouched.
void prepare_projective_solver(const Sheet& sheet, const IntegrateParams& params, ProjectiveSolverPtr& solver);

// Held vertices for this substep: `held[i]` vertex id, `held_target[i]` its prescribed position.
// One backward Euler substep: updates sheet.verts.x and .v. Forces (corner_force, force) are NOT updated
// here; the force system is run after integration for reporting and clustering.
void integrate_substep(const IntegrateParams& params, const std::vector<int32_t>& held,
                       const std::vector<Vec3>& held_target, ProjectiveSolver& solver, Sheet& sheet);

}  // namespace pt
