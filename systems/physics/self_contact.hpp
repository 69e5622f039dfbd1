// Contact of the sheet with itself and between its torn pieces (issue 25; docs/physics.md, "Self-contact").
//
// In the implicit step: self_contact_proximities (below) finds the vertex–triangle pairs near at the
// substep's start or on its predicted path, and the step keeps them apart in its own solve
// (systems/physics/integrate_implicit.hpp, ImplicitParams::self_pairs), so the stiff membrane answers the
// contact in the same step. Impulses after the solve (Bridson's repulsions) kicked single vertices of it:
// a sheet folded onto itself stretched until its fingers slipped, and tore.
//
// After the step, the fail-safe: Bridson, Fedkiw & Anderson 2002 ("Robust treatment of collisions, contact
// and friction for cloth animation"), applied to the substep's motion x0 → x1 (its start and end):
//   1. proximity (their "Proximity detection" and "Repulsions"): vertex–triangle and edge–edge pairs closer
//      than `gap` at x0 that approach over the step get an inelastic impulse plus a repulsion that opens the
//      pair by a tenth of its overlap per step, with Coulomb friction ("Friction") — unless
//      SelfContactParams::repulsions is off, as the engine sets it when the pairs are in the solve;
//   2. continuous collision detection ("Collision detection"): the pairs become coplanar at the roots of a
//      cubic in t ∈ [0, 1] along the straight paths x0 + t (x1 − x0); a root where the pair is closer than
//      `ccd_tolerance` (and than it started) is a collision, stopped by an impulse that leaves the pair
//      `0.1 gap` apart along its normal. Up to `ccd_passes` passes, each over the pairs of the current paths;
//   3. rigid impact zones ("Rigid impact zones", after Provot 1997): the vertices of the pairs still
//      colliding are merged into zones that move rigidly (the zone's momentum and angular momentum), zones
//      grown until no collision is left; a zone that still collides then only translates, which keeps its
//      own pairs as they were at x0.
// x0 must be free of intersections (a sheet starts flat); then x1 is too, as far as the zones converge
// (SelfContactStats::unresolved counts what is left). Both change only positions and velocities: the
// membrane forces the tearing criteria read (Triangles::corner_force, Vertices::force) and the fingers'
// reactions carry no contact force.
// Excluded pairs: a vertex and a triangle it is a corner of, edges that share a vertex, and pairs with a
// corner that is the same pattern point (Vertices::rest) or the same 3D point at x0 as one of the other's:
// the two lips of a tear are duplicated vertices, coincident at its tip (as in systems/self_intersection.hpp);
// and triangles within two gaps of each other in the pattern (a corner inside the other or that near one of
// its edges): the small triangles a cut leaves where a tip advanced by a fraction of a millimetre lie within
// the gap of triangles two rings away, and no contact separates material that near.
// Held vertices (fingers; the engine adds vertices resting on an obstacle) have infinite mass: their paths
// are prescribed. An impulse whose free points carry almost none of the pair's weight is not applied (it
// would fling them); the passes and zones deal with that pair.
// Broad phase (self_contact_candidates): the triangles whose boxes swept over the step and grown by the
// margin overlap, from Embree's rtcCollide (all pairs up to 256 triangles) on boxes grown further, kept
// for the substeps that stay within them. The pairs are sorted, and the impulses applied in that order on
// one thread, so the result is the same at any thread count.
#pragma once

#include "components/sheet.hpp"
#include "systems/common/parallel.hpp"

#include <array>
#include <memory>
#include <vector>

namespace pt {

struct SelfContactParams {
  double gap = 3e-4;          // m: pairs closer than this repel (a few thicknesses of paper)
  double friction = 0.3;      // Coulomb μ between two sheets of paper
  double dt = 1.0 / 300;      // s, the substep
  double ccd_tolerance = 0;   // m: a coplanar pair closer than this collides; 0: gap / 100
  int32_t ccd_passes = 4;     // collision passes before the impact zones
  int32_t zone_passes = 16;   // impact-zone rounds (rigid, then translation)
  // The repulsions after the step. Off when the implicit step kept the vertex–triangle pairs apart in its
  // solve (ProximityPair, below): impulses after it kick single vertices of the stiff membrane (with edge–
  // edge repulsions alone an A5 sheet folded on a table still tore 62 times), and the collision passes and
  // impact zones remain the fail-safe.
  bool repulsions = true;
  // The broad phase's filter and the gathering of the vertex–triangle and edge–edge pairs run in ranges
  // of triangle pairs (systems/common/parallel.hpp), each with its own output, joined in range order.
  RangeRunner run = run_serial;
};

struct SelfContactStats {
  int64_t candidates = 0;   // triangle pairs the broad phase reported (all passes)
  int64_t queries = 0;      // of the broad phase's calls, those that queried (Embree, or all pairs up to
                            // 256 triangles); the others filtered the kept pairs: self_contact_candidates
  int64_t proximities = 0;  // vertex–triangle and edge–edge pairs within the gap at x0 (with the pairs kept
                            // apart in the solve, those pairs: ProximityPair)
  int64_t repulsions = 0;   // of those, pairs an impulse was applied to
  int64_t collisions = 0;   // pairs the CCD passes stopped
  int64_t zones = 0;        // impact zones made rigid
  int64_t unresolved = 0;   // pairs still colliding after the last zone round
  double ms = 0;            // wall time
  SelfContactStats& operator+=(const SelfContactStats& o) {
    candidates += o.candidates;
    queries += o.queries;
    proximities += o.proximities;
    repulsions += o.repulsions;
    collisions += o.collisions;
    zones += o.zones;
    unresolved += o.unresolved;
    ms += o.ms;
    return *this;
  }
};

// Embree's device and scene, kept between substeps.
struct SelfContactBroadPhase;
struct SelfContactBroadPhaseDeleter {
  void operator()(SelfContactBroadPhase*) const;
};
using SelfContactBroadPhasePtr = std::unique_ptr<SelfContactBroadPhase, SelfContactBroadPhaseDeleter>;

// The triangle pairs (s < t, ascending) that share no vertex and whose boxes over the paths x0 → x1 grown
// by `margin` overlap (Embree's rtcCollide, then the exact double-precision box test). Twins of a tear and
// coincident corners are excluded later, element pair by element pair.
// Embree's query runs on boxes grown by a reach that leaves room for the coming substeps' motion, and its
// pairs are kept in `broad`: later calls with the same triangles whose corners stay within the reach of
// where it ran filter those pairs by the exact test only. The pairs are the same either way. Up to 256
// triangles all pairs of boxes are tested instead of Embree's query. Returns whether this call queried.
bool self_contact_candidates(const std::vector<Tri>& tris, const std::vector<Vec3>& x0, const std::vector<Vec3>& x1,
                             double margin, const RangeRunner& run, SelfContactBroadPhasePtr& broad,
                             std::vector<std::array<int32_t, 2>>& pairs);

// The first time t ∈ [0, 1] at which point p meets triangle (a, b, c), all moving linearly from their `0`
// to their `1` positions, within `tolerance`; false when they do not meet. Exposed for the tests.
bool vertex_triangle_ccd(const Vec3& p0, const Vec3& a0, const Vec3& b0, const Vec3& c0, const Vec3& p1,
                         const Vec3& a1, const Vec3& b1, const Vec3& c1, double tolerance, double& t);
// The same for edges (a, b) and (c, d).
bool edge_edge_ccd(const Vec3& a0, const Vec3& b0, const Vec3& c0, const Vec3& d0, const Vec3& a1, const Vec3& b1,
                   const Vec3& c1, const Vec3& d1, double tolerance, double& t);

// A free vertex near a triangle of the sheet that is not its neighbour at the substep's start: a pair the
// implicit step keeps apart in its own solve (systems/physics/integrate_implicit.hpp, ImplicitParams::
// self_pairs), so the membrane answers the contact in the same step instead of to an impulse after it.
struct ProximityPair {
  int32_t vertex = -1;
  std::array<int32_t, 3> triangle{};
  std::array<double, 3> weights{};  // barycentric coordinates of the triangle's point nearest the vertex at x0
  Vec3 normal = Vec3::Zero();       // unit, from that point to the vertex at x0
  double distance = 0;              // between them at x0, m
};

// The vertex–triangle pairs (Bridson et al. 2002's proximities) that are within twice `params.gap` at `x0`,
// or whose predicted paths x0 → x1 may bring them within it: the vertex within twice the gap plus their
// relative displacement of the triangle's nearest point at x0 (the solve's motion is not the prediction's). Neighbours in the sheet are excluded as in
// resolve_self_contact; pairs whose vertex and triangle touch (closer than 1e-6 gap) are left to it, having
// no normal. Sorted by (vertex, triangle): deterministic.
// Returns what it found and took: `proximities` the pairs, `candidates` the broad phase's triangle pairs,
// `ms` its wall time.
SelfContactStats self_contact_proximities(const SelfContactParams& params, const std::vector<Tri>& tris,
                                          const std::vector<Vec2>& rest, const std::vector<Vec3>& x0,
                                          const std::vector<Vec3>& x1, SelfContactBroadPhasePtr& broad,
                                          std::vector<ProximityPair>& out);

// One substep's self-contact: `x0` the positions the substep started from, `inverse_mass` per vertex (0 for
// held vertices), `rest` the pattern positions (twins of a tear), `tris` the triangles; `x` and `v` the
// substep's result, changed in place (an impulse changes v by Δv and x by dt Δv).
SelfContactStats resolve_self_contact(const SelfContactParams& params, const std::vector<Tri>& tris,
                                      const std::vector<Vec2>& rest, const std::vector<Vec3>& x0,
                                      const std::vector<double>& inverse_mass, SelfContactBroadPhasePtr& broad,
                                      std::vector<Vec3>& x, std::vector<Vec3>& v);

}  // namespace pt
