// What the viewer's frames read from the simulation and what they write to it, decoupled from the
// simulation so frames can be drawn while a step runs on the stepper (issue 7): a SheetView copied by a
// frame that owns the simulation, and the edits queued meanwhile, written by the next frame that owns it.
#pragma once

#include "engine/simulation.hpp"

#include <string>
#include <utility>
#include <vector>

namespace pt::viewer {

struct FingerView {
  std::string name;
  Vec2 uv = Vec2::Zero();
  double force = 0;              // |reaction|, N
  bool active = false;           // on the sheet: attached and not released
  bool released = false;
  Vec3 position = Vec3::Zero();  // its vertex's, else its target
  Vec3 goal = Vec3::Zero();      // where it is heading: its last key (or queued move), else its target
};

struct SheetView {
  int frame = 0;
  double time = 0;
  int triangles = 0, vertices = 0, pieces = 0;
  size_t tears = 0;
  std::vector<FingerView> fingers;
  std::vector<Vec3> positions;  // the vertices' (the sheet's extent on screen)
};

// Edits made while a step ran. Finger moves keep only the last target per finger, as
// Simulation::move_finger does for targets set before one step; the live parameters are the panel's copy
// (fracture constant c and tip damage D, propagation speed k and step cap, detail noise σ and ω), each
// group written when it was edited.
struct QueuedEdits {
  std::vector<std::pair<int32_t, Vec3>> moves;
  bool material_edited = false, propagation_edited = false, detail_edited = false;
  double fracture_c = 0, tip_damage = 0;
  double speed = 0, max_step = 0;
  double sigma = 0, omega = 0;
};

// The live parameters of a scenario (nothing marked edited), and the same written back into one (the
// viewer's Reset starts the sheet again with the panel's values).
QueuedEdits live_parameters_of(const Scenario& scenario);
void write_live_parameters(const QueuedEdits& edits, Scenario& scenario);

// Copies what the frame reads; queued moves show as the fingers' goals.
void capture_sheet_view(const Simulation& sim, const QueuedEdits& edits, SheetView& view);

// Queues a finger's new target (replacing one queued before for the same finger).
void queue_finger_move(int32_t finger, const Vec3& target, QueuedEdits& edits);

// Writes the queued edits to the simulation (which no step may be running on) and clears the queue.
// A move of a finger released since it was queued is dropped: a released finger takes no keys.
void apply_queued_edits(QueuedEdits& edits, Simulation& sim);

}  // namespace pt::viewer
