// Linearly implicit backward Euler with a corotated in-plane stiffness (Baraff & Witkin 1998; Müller &
// Gross 2004 for the corotation), the default integrator of papertear.
//
// Why not projective dynamics (docs/architecture.md, "Projective dynamics"): paper's membrane is ~1e5
// times stiffer than its mass term. PD's global matrix penalises every relative motion of a triangle's corners alike, so the
// bending motions that paper makes freely (isometric) converge only over hundreds of iterations and the
// sheet carries a residual stretch of 1e-3 .. 1e-2, i.e. tens of newtons of spurious membrane force —
// far above the ~1 N at which paper tears, so clustering and Griffith's test would read noise. Here the
// stiffness of each triangle acts only in its current plane (R Rᵀ projection), so out-of-plane motion is
// resisted by bending alone and one linear solve per substep gives membrane forces that balance the
// fingers. The price: a numeric factorisation per substep, by the 3x3-block LDLᵀ of systems/solver/block_ldlt.hpp
// (ordering and row patterns reused until the topology or the held set changes).
// Why a fresh factorisation each substep: an earlier factor as the preconditioner of CG does not know a
// triangle's rotation, which moves its huge in-plane stiffness out of plane, and CG then fails to converge
// on 1 000 triangles; CHOLMOD was slower on small sheets (bench/results/2026-12-01-readme-history.md).
//
// Per substep, with h the substep, K the stiffness at the current state (rotations frozen), f the
// membrane + bending forces and f_ext gravity:
//   (M (1 + h α) + (h² + h β) K) v⁺ = M v + h (f + f_ext),   x⁺ = x + h v⁺,
// held vertices (fingers) prescribed: v⁺ = (target − x)/h, eliminated from the system.
//
// K per triangle, in its frame (R the polar rotation of F = R S, g_a the rest gradients of the corners):
// in plane (1 + κ) μ (g_a·g_b) RRᵀ + (1 − κ) μ (R g_b)(R g_a)ᵀ + λ (R g_a)(R g_b)ᵀ, i.e. the energy
// 2μ‖sym G‖² + 2κμ‖skew G‖² + λ tr²G of an in-plane gradient G; out of plane the tension part of the
// geometric stiffness, (g_aᵀ Σ⁺ g_b)(I − RRᵀ). κ = (μ + λ)(σ₁ + σ₂ − 2)/(μ (σ₁ + σ₂)), clamped ≥ 0, makes the
// in-plane block the exact Hessian of the corotated energy (its twist eigenvalue, Smith et al. 2019): an
// in-plane spin costs nothing at rest. With κ = 1 (‖∇u‖²) every spin costs 4μ, and a sheet that lands curled,
// which unfolds through spins (isometric bending of a curved sheet), creeps as through honey.
// Energy check (the spin brake): a linear step rotates triangles linearly, which stretches them by θ²/2
// for a rotation θ per step (out of plane mostly: a curved sheet released from rest, 3.6e-3 rad per step
// is enough at paper's stiffness). After the solve the true membrane energy at x⁺ is compared with the
// linear model the step solved; when the excess exceeds what the step dissipated (so the total energy
// could have grown), the step is redone with κ = 1, 4, 16 (one more factorisation each) and that level
// kept for 10 substeps (ImplicitStats::brakes counts the redos): ~4–9% more factorisations in the
// tearing scenarios, none once a sheet moves slowly.
#pragma once

#include "components/obstacles.hpp"
#include "components/sheet.hpp"
#include "systems/physics/bending_forces.hpp"
#include "systems/physics/membrane_forces.hpp"
#include "systems/physics/self_contact.hpp"
#include "systems/common/parallel.hpp"

#include <memory>

namespace pt {

struct ImplicitParams {
  double dt = 1.0 / 300;            // substep, s
  Vec3 gravity = Vec3(0, 0, -9.81);
  double mass_damping = 2.0;        // α, 1/s
  double stiffness_damping = 1e-4;  // β, s (Rayleigh): damps in-plane ringing of the stiff membrane
  RangeRunner run = run_serial;
  int32_t grain = 512;
  // Springs from free vertices to anchors (a slipping finger's pinch), integrated implicitly with the rest.
  struct Spring {
    int32_t vertex = -1;
    Vec3 anchor = Vec3::Zero();
    double stiffness = 0;  // N/m
  };
  std::vector<Spring> springs;
  // Fixed obstacles (planes, boxes) no free vertex ends a substep inside, grown by contact_offset (m), with
  // Coulomb friction (systems/physics/contact.hpp). Empty: the step is unchanged.
  std::vector<Obstacle> obstacles;
  double contact_offset = 0;
  // Self-contact in the solve (docs/physics.md, "Self-contact"): each pair's vertex, where the step would
  // bring it nearer its triangle than it may come, has its velocity along the pair's normal prescribed to
  // the triangle's there plus what opens the pair to its goal (self_gap), as a vertex resting on a moving
  // obstacle, so the membrane answers in the same solve. Null or empty: the step is unchanged.
  const std::vector<ProximityPair>* self_pairs = nullptr;
  double self_gap = 0;
  // Coulomb μ between a pair's vertex and its triangle, in the solve as on an obstacle, on the velocity
  // relative to the triangle's point: a pair sticks (moves with that point) or slides against it.
  double self_friction = 0;
  // Step splitting (docs/physics.md, "Step splitting"): a step after which a triangle's largest principal
  // strain exceeds both the material's strain limit and its own strain at the step's start by more than
  // `split_strain_jump` is redone as two steps of half the length, at most `max_splits` halvings deep.
  // The linear step stretches what it rotates by θ²/2: lips springing open after a cut rotate fast, and
  // half the step leaves a quarter of that stretch. 0 splits: the step as it was.
  double split_strain_jump = 0.0025;
  int32_t max_splits = 3;
};

struct ImplicitSolver;
struct ImplicitSolverDeleter {
  void operator()(ImplicitSolver*) const;
};
using ImplicitSolverPtr = std::unique_ptr<ImplicitSolver, ImplicitSolverDeleter>;

struct ImplicitStats {
  int64_t analyses = 0;        // symbolic factorisations (the block pattern changed with the topology or held set)
  int64_t factorizations = 0;  // numeric factorisations (one per substep)
  int64_t failures = 0;        // substeps rejected (the state was left unchanged)
  int64_t brakes = 0;          // substeps redone with the spin brake (energy check failed)
  int64_t regularised = 0;     // solves that needed a diagonal shift to factorise (see implicit_substep)
  int64_t contacts = 0;        // vertex-substeps that an obstacle stopped after the solve (systems/physics/contact.hpp)
  int64_t resting_contacts = 0;  // vertex-substeps resting on an obstacle, filtered in the solve
  int64_t arrivals = 0;        // vertices landing on an obstacle, constrained to its surface in a second solve
  int64_t releases = 0;        // resting vertices released because their support would pull (the step solved again)
  int64_t friction_releases = 0;  // stickers set sliding because their support exceeded Coulomb's cap (solved again)
  int64_t splits = 0;          // steps redone as two half steps (ImplicitParams::split_strain_jump)
  // Wall time in ms, summed over the solver's life, of its parts: the block structure after a topology or
  // held-set change (pairs, keys, constant values, destinations; the analysis excluded) and the constant
  // values again after a change of the step (a split), the symbolic
  // analyses, the assembly of matrix values and right-hand side, the numeric factorisations and the
  // triangular solves. Not part of the state: results do not depend on them.
  double structure_ms = 0, analysis_ms = 0, assembly_ms = 0, factorization_ms = 0, solve_ms = 0;
  // The obstacles' part (none without obstacles): resting contacts found, filtered (inside assembly_ms too),
  // their reactions, and the pass after the solve; a release's extra solve counts in the solver's parts.
  double contact_ms = 0;
};
const ImplicitStats& implicit_solver_stats(const ImplicitSolver& solver);
// Heap bytes the solver keeps between substeps (structure, matrix values, factor, scratch), capacity based.
size_t implicit_solver_bytes(const ImplicitSolver& solver);

// One substep. `held[i]` is prescribed to `held_target[i]` at the end of the substep, along a straight
// line (a split step's halves meet at its midpoint). The solver is (re)built when the topology version,
// the held set, the material or dt changed. Writes x, v and the membrane corner forces of the state the
// step started from. Returns false and leaves x, v unchanged if the factorisation failed or the result
// was not finite.
bool implicit_substep(const ImplicitParams& params, const std::vector<int32_t>& held,
                      const std::vector<Vec3>& held_target, ImplicitSolverPtr& solver, Sheet& sheet);

}  // namespace pt
