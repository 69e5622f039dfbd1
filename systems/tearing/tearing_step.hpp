// The tearing step of a frame (paper Fig. 4 steps 2–4): each potential tearing point in turn is
// clustered (eq. 4), tested against Griffith's criterion and given a direction (eqs. 1, 5, 6), cut into
// the mesh (remeshing), and the sheet is relaxed before the next point so the new lips move apart.
// Free functions over the sheet; the relaxation and the listing of candidates are the engine's, passed in
// as hooks, so the step runs without a frame graph or a Simulation.
#pragma once

#include "components/sheet.hpp"
#include "systems/tearing/candidates.hpp"
#include "systems/tearing/clustering.hpp"
#include "systems/tearing/material_force.hpp"
#include "systems/physics/membrane_forces.hpp"
#include "systems/tearing/propagation.hpp"
#include "systems/mesh/remeshing.hpp"
#include "systems/tearing/tension_ray_decision.hpp"

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace pt {

// How a tip's direction t is chosen once Griffith's test passes.
enum class TearDirection {
  Fan,            // eqs. 4–6: minus the bisector of the two force clusters of the tip's fan
  MaterialForce,  // the J-integral's direction of largest energy release (systems/tearing/material_force.hpp)
  TensionRays,    // the load points' shortest paths in the pattern, Er from their reactions
                  // (systems/tearing/tension_ray_decision.hpp)
};

// "bisector" and "fan" → Fan, "material_force" → MaterialForce, "tension_rays" → TensionRays. Returns false
// for any other name.
bool tear_direction_from_name(std::string_view name, TearDirection& out);

// What relaxes the sheet after a propagation (Fig. 4 step 4).
enum class TearRelaxation {
  AfterEachCut,  // hooks.relax after every cut, then the next point is treated on the relaxed sheet
  NextFrame,     // the next frame's physics: the step ends after its first propagation
};

struct TearingParams {
  // Every propagation re-lists the candidates, so a frame's work is bounded by this many propagations.
  int32_t max_propagations = 64;
  // Crack shielding: no new tear starts within this pattern distance (m) of an active tip.
  double shielding_radius = 0.01;
  // Largest turn of a tip per step (rad): at a tip the interior angle is ~2π, so "into the material" alone
  // would accept directions folding the tear back into its own lips.
  double max_tip_turn = 75.0 * 3.14159265358979323846 / 180.0;
  TearDirection direction = TearDirection::Fan;
  double driving_force_radius = 0.04;  // m, the J-integral's domain (MaterialForce only)
  MembraneParams membrane;             // the energy whose material force is integrated (MaterialForce only)
  ClusterParams cluster;
  PropagationParams propagation;
  RemeshParams remesh;                 // the cut (paper §5.3); snap_fraction: snapping of the segment's end
  TearRelaxation relaxation = TearRelaxation::AfterEachCut;
  bool check_invariants = false;       // check_mesh_invariants after every cut, problems to the log
  TensionRayDecisionParams rays;       // TensionRays only
  // Quasi-static tearing: a tip advances again within the frame while Griffith's test holds after the
  // relaxation, so the fingers never out-run the tear. Off: one segment per tear and frame.
  bool quasi_static = false;
};

// The engine's services the step calls; a unit test passes its own. All are required.
struct TearingHooks {
  // Relax the sheet after tear `tear_id` got a segment and bring the forces to the relaxed state
  // (AfterEachCut; timed as relaxation by the step).
  std::function<void(int32_t tear_id)> relax;
  // Bring the forces to the new mesh without moving it (NextFrame: what reads them after the step).
  std::function<void()> update_forces;
  // Rewrite the candidate list the step was given (vertex ids changed with the cut).
  std::function<void()> list_candidates;
};

// Wall time of the step's phases, ms, added to (the relaxation's includes its hook).
struct TearingTimes {
  double clustering = 0, propagation = 0, remeshing = 0, relaxation = 0;
};

// What the step appends to, across frames.
struct TearingLog {
  std::vector<TearEvent> events;
  std::vector<std::string> violations;  // check_invariants: "frame F, tear T: problem"
  int32_t remeshes = 0;                 // segments cut
};

// Per-sheet buffers the step reuses between calls.
struct TearingScratch {
  TensionRayDecisionScratch rays;
  DrivingForceScratch driving;
  std::vector<int32_t> singular_vertices;  // fingers and tips: kept out of a J-integral's domain
};

// True when a new tear starting at `uv` lies within `radius` of an active tip: the tip releases the
// stress around it, and the lips right behind it, loaded by the same field but discretised coarsely,
// would otherwise spawn spurious branches every frame.
bool shielded_by_active_tip(const std::vector<Vec2>& rest, const std::vector<Tip>& tips, const Vec2& uv,
                            double radius);

// Direction of the last segment of tear `tear` (its active tip's), zero when it has no active tip.
Vec2 tip_direction(const std::vector<Tip>& tips, int32_t tear);

// The turn limit: false when `direction` turns more than `max_turn` from the tip's `previous` direction.
// A zero `previous` (a new tear) allows every direction.
bool tip_direction_allowed(const Vec2& previous, const Vec2& direction, double max_turn);

// Fig. 4 step 2 with eq. 6's bound: false, without clustering, when Er ≤ Σ‖f_k‖ / e cannot reach the
// candidate's Ef (or a force is not finite); otherwise the clusters of eq. 4 (false when the vertex is not
// on the boundary).
bool cluster_candidate(const TearingParams& params, const Candidate& c, const Sheet& sheet, ForceClusters& out);

// Fig. 4 step 3's decision (eqs. 1, 5, 6) for a clustered candidate, the direction chosen by
// params.direction. A tear starting at a finger keeps the fan's direction: the finger's point load is
// itself a singularity of the J-integral's domain.
PropagationDecision decide_candidate_propagation(const TearingParams& params, const Candidate& c,
                                                 const ForceClusters& clusters, const Sheet& sheet,
                                                 TearingScratch& scratch);

// The bookkeeping after the segment from `uv` (the candidate's pattern position) to cut.end was cut for
// candidate `c`: a new tear (c.tear < 0) gets id tears.size(), its parent, start kind, frame and uv, and
// a TearStarted event; an existing one a TearExtended event. The tear's path gets cut.end; its tip moves
// to cut.tip_vertex with the segment's direction, or is removed when the tear reached the boundary.
// `separated` (the cut split off a piece) adds a PieceSeparated event. Returns the tear's id.
int32_t record_tear_segment(const Candidate& c, const Vec2& uv, const CutResult& cut, int32_t parent,
                            bool separated, int32_t frame, std::vector<Tear>& tears, std::vector<Tip>& tips,
                            std::vector<TearEvent>& events);

// kFinger on held vertices and kTip on active tips, cleared elsewhere.
void refresh_role_flags(const std::vector<Finger>& fingers, const std::vector<Tip>& tips,
                        std::vector<uint8_t>& flags);

// The decision at candidate c, nothing cut: the tension rays' (TensionRays) or Fig. 4 steps 2–3 on its fan
// (the others; no propagation when the fan cannot reach Griffith's threshold). Timed into `times`.
PropagationDecision candidate_decision(const TearingParams& params, const Candidate& c, const Sheet& sheet,
                                       TearingTimes& times, TearingScratch& scratch);

// Of the start candidates (no tear) from index `first` on that are not shielded, the index of the one
// whose decision propagates with the largest Er/Ef (the first in order on a tie), its decision in
// `decision`; −1 when none does.
int32_t strongest_start(const TearingParams& params, const std::vector<Candidate>& candidates, size_t first,
                        const Sheet& sheet, TearingTimes& times, TearingScratch& scratch,
                        PropagationDecision& decision);

// Turn limit, cut and bookkeeping for one candidate whose decision is taken (Fig. 4 step 3, no
// relaxation). Returns the id of the tear that got a segment, −1 when nothing was cut.
int32_t cut_candidate(const TearingParams& params, const Candidate& c, const PropagationDecision& decision,
                      int32_t frame, Sheet& sheet, TearingLog& log, TearingTimes& times);

// Clustering, decision, turn limit, cut and bookkeeping for one candidate (Fig. 4 steps 2–3, no
// relaxation): candidate_decision, then cut_candidate.
int32_t propagate_candidate(const TearingParams& params, const Candidate& c, int32_t frame, Sheet& sheet,
                            TearingLog& log, TearingTimes& times, TearingScratch& scratch);

// Whether the step would cut anything now with TensionRays: some candidate, tip or start, that is not
// shielded, passes Griffith's test and points into the material within the turn limit. The engine stops
// a frame's physics at the first substep where this holds, so a start is caught at the load that starts
// it, not at the end of the frame (quasi-static tearing).
bool tension_rays_would_tear(const TearingParams& params, const std::vector<Candidate>& candidates,
                             const Sheet& sheet, TearingScratch& scratch);

// The frame's tearing step: the candidates in order (hooks.list_candidates rewrites `candidates` after
// each propagation and the list is walked again from its start), each pattern position and each tear
// treated at most once, new starts near an active tip skipped, at most params.max_propagations
// propagations, each followed by the relaxation. With quasi_static, one start at most, before any cut:
// the strongest (strongest_start).
void run_tearing_step(const TearingParams& params, const TearingHooks& hooks, const std::vector<Candidate>& candidates,
                      int32_t frame, Sheet& sheet, TearingLog& log, TearingTimes& times, TearingScratch& scratch);

}  // namespace pt
