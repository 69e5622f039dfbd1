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
  // Weight of the corotated area term λ/2 tr(RᵀF − I)² in the local step (1: the energy of membrane_forces,
  // 0: plain ARAP, the λ term is then ignored by the integrator). See integrate.cpp.
  double area_term = 1.0;
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

// Health and counters of a solver (read after integrate_substep).
struct ProjectiveStats {
  bool ok = true;                 // the last substep succeeded (false: the state was left unchanged)
  bool factorization_ok = true;   // the last factorisation succeeded
  int64_t factorizations = 0;     // how many times the matrix was (re)factorised
  int64_t substeps = 0;
  int64_t failures = 0;           // substeps rejected (failed solve or non-finite result)
};
const ProjectiveStats& projective_solver_stats(const ProjectiveSolver& solver);

// Held vertices for this substep: `held[i]` vertex id, `held_target[i]` its prescribed position.
// One backward Euler substep: updates sheet.verts.x and .v. Forces (corner_force, force) are NOT updated
// here; the force system is run after integration for reporting and clustering.
// Returns false (and leaves x, v unchanged) if the solve failed or produced a non-finite value. If `held`
// differs from the set prepare_projective_solver saw (fingers' vertices), the solver is rebuilt here.
// The held set of prepare_projective_solver is {Finger::vertex ≥ 0}; material changes also rebuild.
bool integrate_substep(const IntegrateParams& params, const std::vector<int32_t>& held,
                       const std::vector<Vec3>& held_target, ProjectiveSolver& solver, Sheet& sheet);

}  // namespace pt
