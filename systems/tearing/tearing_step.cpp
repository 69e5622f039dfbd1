#include "systems/tearing/tearing_step.hpp"

#include "systems/common/scoped_timer.hpp"
#include "systems/common/topology.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>
#include <utility>


namespace pt {

bool tear_direction_from_name(std::string_view name, TearDirection& out) {
  if (name == "bisector" || name == "fan") {
    out = TearDirection::Fan;
    return true;
  }
  if (name == "material_force") {
    out = TearDirection::MaterialForce;
    return true;
  }
  if (name == "tension_rays") {
    out = TearDirection::TensionRays;
    return true;
  }
  return false;
}

bool shielded_by_active_tip(const std::vector<Vec2>& rest, const std::vector<Tip>& tips, const Vec2& uv,
                            double radius) {
  for (const Tip& t : tips)
    if ((rest[t.vertex] - uv).norm() < radius) return true;
  return false;
}

Vec2 tip_direction(const std::vector<Tip>& tips, int32_t tear) {
  Vec2 direction = Vec2::Zero();
  for (const Tip& t : tips)
    if (t.tear == tear) direction = t.direction;
  return direction;
}

bool tip_direction_allowed(const Vec2& previous, const Vec2& direction, double max_turn) {
  // Written as the refusal: a direction whose dot product is NaN is not refused here but left to the
  // decision and the cut, which reject non-finite steps.
  return !(previous.squaredNorm() > 0 && previous.dot(direction) < std::cos(max_turn));
}

bool cluster_candidate(const TearingParams& params, const Candidate& c, const Sheet& sheet, ForceClusters& out) {
  // Er ≤ Σ‖f_k‖ / e (eq. 6 with cos(φ/2) ≤ 1): a candidate that cannot reach Griffith's threshold is not
  // clustered, as its decision would be "no" anyway; NaN forces are skipped too (the decision refuses them).
  if (!(fan_force_sum(sheet.tris, sheet.topo, c.vertex) / params.propagation.thickness >= c.fracture_energy))
    return false;
  return cluster_tip_forces(sheet.verts, sheet.tris, sheet.topo, c.vertex, params.cluster, out);
}

PropagationDecision decide_candidate_propagation(const TearingParams& params, const Candidate& c,
                                                 const ForceClusters& clusters, const Sheet& sheet,
                                                 TearingScratch& scratch) {
  PropagationParams prop = params.propagation;
  if (c.tear >= 0) prop.previous_direction = tip_direction(sheet.tips, c.tear);
  PropagationDecision decision =
      decide_propagation(clusters, sheet.topo, sheet.verts.rest, c.vertex, c.fracture_energy, prop);
  // With MaterialForce, t is the direction of the crack driving force (the J-integral over the tip's
  // surroundings) rather than the bisector of its fan's two clusters. Er and Griffith's test do not depend
  // on t, so only a point that passes them pays for the domain integral.
  const bool at_finger = c.tear < 0 && c.kind == StartKind::Finger;
  if (params.direction != TearDirection::MaterialForce || !decision.griffith || at_finger) return decision;
  scratch.singular_vertices.clear();
  for (const Finger& f : sheet.fingers) scratch.singular_vertices.push_back(f.vertex);
  for (const Tip& t : sheet.tips) scratch.singular_vertices.push_back(t.vertex);
  const double radius =
      domain_radius(sheet.verts.rest, c.vertex, scratch.singular_vertices, params.driving_force_radius);
  const DrivingForce force = crack_driving_force(sheet.verts, sheet.tris, sheet.topo, c.vertex, radius,
                                                 params.membrane, scratch.driving);
  if (force.j.squaredNorm() > 0) {
    prop.driving_direction = force.j.normalized();
    decision = decide_propagation(clusters, sheet.topo, sheet.verts.rest, c.vertex, c.fracture_energy, prop);
  }
  return decision;
}

int32_t record_tear_segment(const Candidate& c, const Vec2& uv, const CutResult& cut, int32_t parent,
                            bool separated, int32_t frame, std::vector<Tear>& tears, std::vector<Tip>& tips,
                            std::vector<TearEvent>& events) {
  int32_t tear_id = c.tear;
  if (tear_id < 0) {
    tear_id = static_cast<int32_t>(tears.size());  // ids are indices: tears are never removed
    Tear t;
    t.id = tear_id;
    t.parent = parent;
    t.start_kind = c.kind;
    t.start_frame = frame;
    t.start_uv = uv;
    t.tips.push_back(uv);
    tears.push_back(t);
    events.push_back({TearEvent::TearStarted, tear_id, frame});
  } else {
    events.push_back({TearEvent::TearExtended, tear_id, frame});
  }
  Tear& tear = tears[tear_id];
  tear.tips.push_back(cut.end);
  const Vec2 d = cut.end - uv;
  if (tear.advance_frame != frame) tear.advance_frame = frame, tear.frame_advance = 0;
  tear.frame_advance += d.norm();
  tear.max_frame_advance = std::max(tear.max_frame_advance, tear.frame_advance);
  const Vec2 dir = d.norm() > 0 ? Vec2(d / d.norm()) : Vec2::Zero();
  tips.erase(std::remove_if(tips.begin(), tips.end(), [&](const Tip& t) { return t.tear == tear_id; }), tips.end());
  if (cut.reached_boundary) {
    tear.reached_boundary = true;
  } else {
    tips.push_back(Tip{cut.tip_vertex, tear_id, dir});
  }
  if (separated) events.push_back({TearEvent::PieceSeparated, tear_id, frame});
  return tear_id;
}

void refresh_role_flags(const std::vector<Finger>& fingers, const std::vector<Tip>& tips,
                        std::vector<uint8_t>& flags) {
  for (uint8_t& f : flags) f &= static_cast<uint8_t>(~(kFinger | kTip));
  for (const Finger& f : fingers)
    if (f.vertex >= 0) flags[f.vertex] |= kFinger;
  for (const Tip& t : tips) flags[t.vertex] |= kTip;
}

namespace {

// A new tear not started here: an active tip relieves the paper around it, a pinching finger's point
// included. Split by the tear it has just started, that point would otherwise start more from itself, a
// few degrees apart: slivers of paper.
bool start_shielded(const TearingParams& params, const Candidate& c, const Sheet& sheet) {
  return c.tear < 0 &&
         shielded_by_active_tip(sheet.verts.rest, sheet.tips, sheet.verts.rest[c.vertex], params.shielding_radius);
}

// The tension rays' decision for candidate c, a tip oriented by its last segment.
PropagationDecision tension_ray_candidate_decision(const TearingParams& params, const Candidate& c,
                                                   const Sheet& sheet, TearingScratch& scratch) {
  PropagationParams prop = params.propagation;
  if (c.tear >= 0) prop.previous_direction = tip_direction(sheet.tips, c.tear);
  return decide_by_tension_rays(sheet, c.vertex, c.fracture_energy, c.tear < 0, prop, params.membrane,
                                params.rays, scratch.rays);
}

}  // namespace

PropagationDecision candidate_decision(const TearingParams& params, const Candidate& c, const Sheet& sheet,
                                       TearingTimes& times, TearingScratch& scratch) {
  if (params.direction == TearDirection::TensionRays) {
    ScopedTimer timer(times.propagation);
    return tension_ray_candidate_decision(params, c, sheet, scratch);
  }
  ForceClusters clusters;
  {
    ScopedTimer timer(times.clustering);
    if (!cluster_candidate(params, c, sheet, clusters)) return PropagationDecision{};
  }
  ScopedTimer timer(times.propagation);
  return decide_candidate_propagation(params, c, clusters, sheet, scratch);
}

int32_t cut_candidate(const TearingParams& params, const Candidate& c, const PropagationDecision& decision,
                      int32_t frame, Sheet& sheet, TearingLog& log, TearingTimes& times) {
  if (!decision.propagate) return -1;
  const Vec2 previous = c.tear >= 0 ? tip_direction(sheet.tips, c.tear) : Vec2(Vec2::Zero());
  if (c.tear >= 0 && !tip_direction_allowed(previous, decision.direction, params.max_tip_turn)) return -1;

  // Fig. 4 step 3's remeshing: the segment p → p_next is cut into the mesh, then recorded.
  ScopedTimer timer(times.remeshing);
  const Vec2 uv = sheet.verts.rest[c.vertex];
  const int32_t tear_id = c.tear >= 0 ? c.tear : static_cast<int32_t>(sheet.tears.size());
  const int32_t parent = c.tear < 0 ? sheet.verts.tear[c.vertex] : -1;  // a branch of the tear it starts on
  const int32_t pieces_before = sheet.topo.piece_count;
  const double area_before = params.check_invariants ? total_rest_area(sheet.tris) : -1.0;
  // With the tension rays an inward corner starts by the rays' rule whatever else flags it: say so (read
  // before the cut renumbers the vertices).
  Candidate started = c;
  if (params.direction == TearDirection::TensionRays && c.tear < 0 && c.kind == StartKind::Junction &&
      interior_pattern_angle(sheet.topo, sheet.verts.rest, c.vertex) > std::numbers::pi + 1e-9)
    started.kind = StartKind::Inward;
  const CutResult cut = cut_tear_segment(c.vertex, decision.next, previous, tear_id, params.remesh, sheet);
  if (!cut.cut) return -1;
  ++log.remeshes;
  if (params.check_invariants) {
    const std::string problem = check_mesh_invariants(sheet, area_before);
    if (!problem.empty())
      log.violations.push_back("frame " + std::to_string(frame) + ", tear " + std::to_string(tear_id) + ": " +
                               problem);
  }
  record_tear_segment(started, uv, cut, parent, sheet.topo.piece_count > pieces_before, frame, sheet.tears, sheet.tips,
                      log.events);
  refresh_role_flags(sheet.fingers, sheet.tips, sheet.verts.flags);
  return tear_id;
}

int32_t propagate_candidate(const TearingParams& params, const Candidate& c, int32_t frame, Sheet& sheet,
                            TearingLog& log, TearingTimes& times, TearingScratch& scratch) {
  return cut_candidate(params, c, candidate_decision(params, c, sheet, times, scratch), frame, sheet, log, times);
}

bool tension_rays_would_tear(const TearingParams& params, const std::vector<Candidate>& candidates,
                             const Sheet& sheet, TearingScratch& scratch) {
  for (const Candidate& c : candidates) {
    if (c.vertex < 0 || c.vertex >= sheet.verts.size() || start_shielded(params, c, sheet)) continue;
    const PropagationDecision d = tension_ray_candidate_decision(params, c, sheet, scratch);
    if (!d.propagate) continue;
    if (c.tear >= 0 && !tip_direction_allowed(tip_direction(sheet.tips, c.tear), d.direction, params.max_tip_turn))
      continue;
    return true;
  }
  return false;
}

int32_t strongest_start(const TearingParams& params, const std::vector<Candidate>& candidates, size_t first,
                        const Sheet& sheet, TearingTimes& times, TearingScratch& scratch,
                        PropagationDecision& decision) {
  int32_t best = -1;
  double best_ratio = 0;
  for (size_t i = first; i < candidates.size(); ++i) {
    const Candidate& c = candidates[i];
    if (c.tear >= 0 || start_shielded(params, c, sheet)) continue;
    const PropagationDecision d = candidate_decision(params, c, sheet, times, scratch);
    const double ratio = d.energy_release / c.fracture_energy;
    if (d.propagate && (best < 0 || ratio > best_ratio)) {
      best = static_cast<int32_t>(i);
      best_ratio = ratio;
      decision = d;
    }
  }
  return best;
}

void run_tearing_step(const TearingParams& params, const TearingHooks& hooks, const std::vector<Candidate>& candidates,
                      int32_t frame, Sheet& sheet, TearingLog& log, TearingTimes& times, TearingScratch& scratch) {
  std::set<std::pair<double, double>> visited;  // pattern positions already treated this frame
  std::set<int32_t> extended;                   // tears already propagated this frame
  size_t index = 0;
  int32_t propagations = 0;
  bool start_judged = false;  // quasi-static: the stop's one start was chosen
  while (index < candidates.size() && propagations < params.max_propagations) {
    Candidate c = candidates[index++];  // a copy: list_candidates rewrites the list
    // Quasi-static tearing judges a start only at the state the physics stopped at: after a cut the forces
    // are the relaxation substep's, whose lips are still springing open, and a start read there is a
    // transient's (fig18-crumple started a fourth tear so). Tips go on advancing; starts wait for the next
    // stop, after the sheet has moved on from the cut. Of the starts due at a stop the one with the
    // largest Er/Ef starts: as the load grew it reached Griffith's threshold first. The candidates' order,
    // by vertex id, must not choose (start-finger's pinching finger and the edge beside it are often due at
    // one stop: over four meshes it made 1-6 tears at up to 12 N when the lower id started, 1-4 at up to
    // 5.3 N now).
    PropagationDecision start;  // the chosen start's decision, taken once
    if (c.tear < 0 && params.quasi_static) {
      if (propagations > 0 || start_judged) continue;
      start_judged = true;
      const int32_t best = strongest_start(params, candidates, index - 1, sheet, times, scratch, start);
      if (best < 0) continue;
      c = candidates[best];
    }
    const Vec2 uv = sheet.verts.rest[c.vertex];
    if (!visited.insert({uv.x(), uv.y()}).second) continue;
    if (c.tear >= 0 && !params.quasi_static && extended.count(c.tear)) continue;
    if (start_shielded(params, c, sheet)) continue;

    const int32_t tear_id = start.propagate ? cut_candidate(params, c, start, frame, sheet, log, times)
                                            : propagate_candidate(params, c, frame, sheet, log, times, scratch);
    if (tear_id < 0) continue;
    extended.insert(tear_id);
    if (params.relaxation == TearRelaxation::NextFrame) {
      // The next frame's physics is this propagation's relaxation, and no other point propagates before
      // it. The forces and candidates are brought to the new mesh (ids changed) for what reads them.
      hooks.update_forces();
      hooks.list_candidates();
      break;
    }
    {
      // Fig. 4 step 4: the lips move apart before the next point is treated.
      ScopedTimer timer(times.relaxation);
      hooks.relax(tear_id);
    }
    // Vertex ids changed: find the candidates again and go on with the ones not yet treated.
    hooks.list_candidates();
    index = 0;
    ++propagations;
  }
}

}  // namespace pt
