#include "apps/viewer/sheet_view.hpp"

#include "engine/simulation_internals.hpp"

namespace pt::viewer {

void capture_sheet_view(const Simulation& sim, const QueuedEdits& edits, SheetView& view) {
  const Sheet& s = sim.sheet();
  view.frame = sim.frame();
  view.time = sim.time();
  view.triangles = s.tris.size();
  view.vertices = s.verts.size();
  view.pieces = s.topo.piece_count;
  view.tears = s.tears.size();
  view.positions.assign(s.verts.x.begin(), s.verts.x.end());
  view.fingers.resize(s.fingers.size());
  for (size_t i = 0; i < s.fingers.size(); ++i) {
    const Finger& f = s.fingers[i];
    FingerView& v = view.fingers[i];
    v.name = f.name;
    v.uv = f.uv;
    v.force = f.reaction.norm();
    v.active = f.vertex >= 0 && !f.released;
    v.released = f.released;
    v.position = f.vertex >= 0 ? s.verts.x[f.vertex] : f.target;
    // A finger in a hand follows the hand's motion; its own keys are not where it is heading.
    v.goal = (!f.keys.empty() && f.hand < 0) ? f.keys.back().position : f.target;
  }
  for (const auto& [i, target] : edits.moves)
    if (i >= 0 && i < static_cast<int32_t>(view.fingers.size())) view.fingers[i].goal = target;
}

void queue_finger_move(int32_t finger, const Vec3& target, QueuedEdits& edits) {
  for (auto& [i, t] : edits.moves)
    if (i == finger) {
      t = target;
      return;
    }
  edits.moves.push_back({finger, target});
}

void apply_queued_edits(QueuedEdits& edits, Simulation& sim) {
  for (const auto& [i, target] : edits.moves) {
    if (i < 0 || i >= static_cast<int32_t>(sim.sheet().fingers.size())) continue;
    const Finger& f = sim.sheet().fingers[i];
    if (f.vertex < 0 || f.released) continue;
    // A drag along a ray nearly parallel to the view plane can reach past what the engine takes (each
    // coordinate within 1000 m): that move is dropped and the finger keeps its last target.
    try {
      sim.move_finger(i, target);
    } catch (const InputError&) {
    }
  }
  edits.moves.clear();
  if (edits.material_edited) {
    mutable_sheet(sim).material.fracture_c = edits.fracture_c;
    mutable_sheet(sim).material.tip_damage = edits.tip_damage;
    edits.material_edited = false;
  }
  if (edits.propagation_edited) {
    sim.set_propagation_speed(edits.speed, edits.max_step);
    edits.propagation_edited = false;
  }
  if (edits.detail_edited) {
    sim.set_detail_noise(edits.sigma, edits.omega);
    edits.detail_edited = false;
  }
}

QueuedEdits live_parameters_of(const Scenario& scenario) {
  QueuedEdits e;
  const Material& m = scenario.material;
  e.fracture_c = m.fracture_c;
  e.tip_damage = m.tip_damage;
  e.speed = m.speed;
  e.max_step = m.max_step;
  e.sigma = scenario.detail.sigma;
  e.omega = scenario.detail.omega;
  return e;
}

void write_live_parameters(const QueuedEdits& edits, Scenario& scenario) {
  Material& m = scenario.material;
  m.fracture_c = edits.fracture_c;
  m.tip_damage = edits.tip_damage;
  m.speed = edits.speed;
  m.max_step = edits.max_step;
  scenario.detail.sigma = edits.sigma;
  scenario.detail.omega = edits.omega;
}

}  // namespace pt::viewer
