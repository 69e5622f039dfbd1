// Contact of the sheet's vertices with fixed obstacles (planes, boxes) with Coulomb friction, in the implicit
// substep (systems/physics/integrate_implicit.cpp; docs/physics.md, "Obstacles").
//
// Method: constraint filtering in the linear solve (Baraff & Witkin 1998, "Large steps", §5). A vertex
// resting on an obstacle grown by `offset` at the substep's start has its velocity into it filtered out of
// the system (v = S y + n z, S = I − n nᵀ, the matrix S A S plus c n nᵀ so the pattern and the ordering of
// the factorisation are unchanged); a vertex whose step would enter an obstacle is constrained the same way
// with z = −gap/h, so it lands on the surface, and the step is solved again; a support whose reaction
// would pull is released and the step solved again (a few rounds). Friction is Coulomb's, in the solve: a
// constrained vertex sticks (its whole velocity prescribed) while the tangential impulse of its support
// stays within μ λ, λ its normal impulse n·(A v − b); otherwise it slides with the impulse μ λ against its
// motion on the right-hand side, and a slider whose momentum along the surface is within μ λ sticks; the
// step ends with rounds that only release stickers past μ λ, so none holds more however many rings of
// stickers a push has to load (docs/physics.md, "Coulomb's cap holds for the whole sheet"). Last,
// every free vertex still inside an obstacle (what the rounds left) is put back on its surface, its
// velocity into it removed and friction applied (`resolve_vertex_contact`, after Bridson, Fedkiw & Anderson
// 2002), so the invariant is exact: no free vertex ends a substep inside an obstacle.
// Why filtering rather than projecting after the solve, or a barrier: the stiff membrane must see the
// support in the same solve — projecting after it stretched the paper (a sheet dropped over a box gained
// 1.7 mJ at its impact and never came to rest), and a barrier stiff enough for paper's 4·10⁵ N/m membrane
// needs line searches the linearly implicit step does not have. Filtering keeps the energy check valid (a
// resting vertex's reaction does no work) and the matrix's pattern; with no obstacle nothing runs, so every
// scenario without one keeps its bits. Friction after the solve (each vertex's tangential velocity cut
// alone) stretched the membrane the same way: pieces landing on a floor reached 16% strain and tore three
// more times; in the solve they land as torn-in-two hangs (3.7%). The price: a contact that changes costs a
// factorisation more, and a sheet resting on a table two per substep (normal filter, then the stickers).
// Contact reactions never enter verts.force, so the fingers'
// reactions (systems/physics/grip.hpp) and the membrane forces the tearing criteria read carry none.
#pragma once

#include "components/obstacles.hpp"
#include "components/sheet.hpp"

#include <vector>

namespace pt {

struct ContactParams {
  double offset = 0;  // m: a vertex stays this far outside every obstacle (half the sheet's thickness)
  double dt = 0;      // s, the substep
};

// Resolves the contacts of one vertex that moved from `start` to `x` with velocity `v` over the substep
// against `obstacles`, in their order (a few sweeps, so a vertex in a corner ends outside both). Returns
// true when it touched one.
bool resolve_vertex_contact(const std::vector<Obstacle>& obstacles, const ContactParams& params, const Vec3& start,
                            Vec3& x, Vec3& v);

// The first of `obstacles` (in order) whose surface, grown by `offset`, the step start → x enters: its
// outward unit normal, a point `on` it and its friction.
bool entered_surface(const std::vector<Obstacle>& obstacles, double offset, const Vec3& start, const Vec3& x,
                     Vec3& normal, Vec3& on, double& friction);

// Whether `x` rests on obstacle `o` grown by `offset`: within `tolerance` of its surface (either side). Then
// `normal` is the surface's outward unit normal there (for a box, of the nearest face).
bool resting_contact_normal(const Obstacle& o, double offset, double tolerance, const Vec3& x, Vec3& normal);

// Signed distance of `p` from the obstacle's surface, positive outside (for a box: the largest of the
// face distances inside, the Euclidean distance outside).
double obstacle_distance(const Obstacle& obstacle, const Vec3& p);

}  // namespace pt
