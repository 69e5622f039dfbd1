// The frame graph of one sheet (docs/architecture.md "The frame"). Built once per sheet; each node is named
// after the system it runs. Parallelism comes from two places: the kernels inside a node run their ranges
// with oneTBB (forces, the factorisation) inside the sheet's task arena, and the carving of the
// previous frame's segments runs beside this frame's physics, since it only reads tips that are fixed.
#include "engine/simulation.hpp"

#include "engine/sheet_builder.hpp"
#include "engine/simulation_internals.hpp"
#include "systems/common/pattern_geometry.hpp"
#include "systems/physics/bending_forces.hpp"
#include "systems/tearing/candidates.hpp"
#include "systems/carving/carving.hpp"
#include "systems/physics/fingers.hpp"
#include "systems/physics/contact.hpp"
#include "systems/physics/grip.hpp"
#include "systems/physics/integrate_implicit.hpp"
#include "systems/physics/local_relaxation.hpp"
#include "systems/physics/membrane_forces.hpp"
#include "systems/physics/self_contact.hpp"
#include "systems/tearing/regions.hpp"
#include "systems/common/scoped_timer.hpp"
#include "systems/common/topology.hpp"
#include "systems/tearing/tearing_step.hpp"
#include "systems/mesh/vertex_insertion.hpp"

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/flow_graph.h>
#include <oneapi/tbb/info.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/partitioner.h>
#include <oneapi/tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <numbers>
#include <stdexcept>

namespace pt {

namespace {

using Clock = std::chrono::steady_clock;

uint64_t fnv1a(uint64_t h, const void* data, size_t bytes) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < bytes; ++i) {
    h ^= p[i];
    h *= 1099511628211ull;
  }
  return h;
}

// Interactive targets obey a scenario file's limit on key positions (engine/scenario.cpp, README).
constexpr double kMaxTarget = 1000;  // m

std::string fmt_point(const Vec3& p) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "(%.6g, %.6g, %.6g)", p.x(), p.y(), p.z());
  return buf;
}

// The finger an interactive call names: an index the caller got from the sheet, else InputError.
Finger& finger_of(Sheet& sheet, int32_t finger, const char* call) {
  const int32_t n = static_cast<int32_t>(sheet.fingers.size());
  if (finger < 0 || finger >= n)
    throw InputError(std::string(call) + ": no finger " + std::to_string(finger) +
                     (n == 0 ? std::string(" (the sheet has no fingers)")
                             : " (the sheet has fingers 0 to " + std::to_string(n - 1) + ")"));
  return sheet.fingers[finger];
}

}  // namespace

void TimingReport::add(const FrameProfile& p) {
  for (size_t i = 0; i < kSystems.size(); ++i) systems[i].add(p.*kSystems[i].ms);
  physics.add(p.physics());
  geometry.add(p.geometry());
  tearing.add(p.tearing());
  carving.add(p.carving);
  frame.add(p.frame);
}

std::string hash_sheet(const Sheet& s) {
  uint64_t h = 1469598103934665603ull;
  h = fnv1a(h, s.verts.x.data(), s.verts.x.size() * sizeof(Vec3));
  h = fnv1a(h, s.verts.v.data(), s.verts.v.size() * sizeof(Vec3));
  h = fnv1a(h, s.verts.rest.data(), s.verts.rest.size() * sizeof(Vec2));
  h = fnv1a(h, s.tris.tri.data(), s.tris.tri.size() * sizeof(Tri));
  for (const Tear& t : s.tears) {
    h = fnv1a(h, &t.id, sizeof t.id);
    h = fnv1a(h, &t.parent, sizeof t.parent);
    h = fnv1a(h, t.tips.data(), t.tips.size() * sizeof(Vec2));
    h = fnv1a(h, t.detail.data(), t.detail.size() * sizeof(Vec2));
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

struct Simulation::Impl {
  Scenario scenario;
  EngineOptions options;
  Sheet sheet;
  FiberField fiber;
  DetailParams detail;
  CarveState carve_state;

  ImplicitParams implicit_params;
  ImplicitSolverPtr implicit;
  MembraneParams membrane;
  std::vector<BendingStencil> bending;
  uint64_t bending_version = ~uint64_t{0};
  RegionParams region_params;
  TearingParams tearing_params;  // clustering, propagation, remeshing and direction of the tearing step
  // "sim": {"relaxation": ...}: an extra substep of the sheet, the next frame's physics, or a patch's substep.
  enum class Relaxation { Substep, NextFrame, Patch } relaxation = Relaxation::Substep;
  LocalRelaxationParams local_relaxation;
  LocalRelaxationScratch local_scratch;
  // "sim": {"self_contact": ...}: Bridson's pass after each substep (systems/physics/self_contact.hpp).
  SelfContactParams self_contact;
  SelfContactBroadPhasePtr self_contact_broad;
  SelfContactStats self_contact_stats;   // summed over the run
  std::vector<Vec3> self_contact_start;  // x the substep started from
  std::vector<Vec3> self_contact_predicted;  // and where it would go: x + h v, held vertices at their targets
  std::vector<ProximityPair> self_pairs;  // kept apart in the implicit solve
  std::vector<double> self_contact_inverse_mass;
  std::function<void(const Sheet&)> substep_observer;  // tests: called after each substep
  int64_t patch_failures = 0;  // patch relaxations the implicit step refused (reported with the solver's)
  TearingScratch tearing_scratch;

  // e, k and the step bounds of p_next = p + k·Er·t from the material (at start and on a live edit).
  void take_propagation_params(const Material& m) {
    PropagationParams& p = tearing_params.propagation;
    p.thickness = m.thickness;
    p.speed = m.speed;
    p.max_step = m.max_step;
    p.min_step = std::min(m.min_step, m.max_step);
  }

  int32_t frame = 0;
  std::string stop_reason;  // set when a vertex left ±kMaxSheetPosition: no further frames run
  std::vector<Vec3> targets_begin;  // finger targets at the start of the frame
  int32_t resume_substep = -1;     // the substep a frame stopped for tearing resumes at (stops_for_tearing)
  bool last_substep_rerun = false; // the frame's last substep stopped once and runs again to its end
  double physics_alpha = 1.0;      // how far through the frame's finger motion the physics is (1 unless stopped)
  std::vector<Vec3> hold_points;  // per finger: scratch of the pinches and the re-grip after a cut
  std::vector<Mat3> pad_rotations;  // per finger: scratch of the re-grip's pad rotations
  // A slipping pinch pulls like this spring, its force capped at the grip: the grip within ~2 mm.
  static constexpr double kPinchStiffness = 7500;  // N/m
  std::vector<Candidate> candidates;
  FiberSampleCache fiber_cache;  // T_fiber per vertex for the candidates' Ef
  FrameProfile profile;
  TimingReport timings;
  std::vector<FrameStats> stats;
  RegionSummary region_summary;
  TearingLog tearing_log;  // events, invariant violations and the count of cuts
  double max_strain = 0;              // largest principal in-plane strain at the end of any frame so far
  double max_strain_beyond_tips = 0;  // the same over triangles beyond kTipZone of the tips (beyond_tips)
  std::vector<double> triangle_strain;  // per triangle, for it

  tbb::task_arena arena;
  std::unique_ptr<tbb::flow::graph> graph;
  std::unique_ptr<tbb::flow::broadcast_node<tbb::flow::continue_msg>> start;
  std::vector<std::unique_ptr<tbb::flow::continue_node<tbb::flow::continue_msg>>> nodes;
  std::vector<std::function<void()>> systems_in_order;  // the nodes' bodies in creation order, a topological one

  Impl(const Scenario& s, const EngineOptions& o) : scenario(s), options(o), arena(std::max(1, o.threads)) {
    sheet = build_sheet(scenario);
    for (int32_t v = 0; v < sheet.verts.size(); ++v)
      if (sheet.verts.flags[v] & kInward) outline_corners.push_back(sheet.verts.rest[v]);
    fiber = make_fiber_field(scenario);
    const auto size = texture_size(scenario);
    detail.origin = fiber.origin;
    detail.pixel_size = fiber.pixel_size;
    detail.width = size[0];
    detail.height = size[1];
    detail.sigma = scenario.detail.sigma;
    detail.omega = scenario.detail.omega;

    const Material& m = sheet.material;
    implicit_params.dt = 1.0 / (scenario.sim.fps * scenario.sim.substeps);
    implicit_params.gravity = scenario.sim.gravity;
    implicit_params.mass_damping = m.damping;
    implicit_params.max_splits = scenario.sim.step_splits;
    implicit_params.split_strain_jump = scenario.sim.split_strain_jump;
    implicit_params.grain = options.parallel_grain;
    implicit_params.run = [this](int32_t count, int32_t grain, const RangeTask& task) {
      run_ranges(count, grain, task);
    };
    // Obstacles with unit normals (validated non-zero; scaled first, so a tiny normal's norm cannot
    // underflow), grown by half the sheet's thickness: its mid-surface lies that far above a table.
    implicit_params.obstacles = scenario.obstacles;
    for (Obstacle& o : implicit_params.obstacles)
      if (o.kind == Obstacle::Kind::Plane) o.normal = (o.normal / o.normal.cwiseAbs().maxCoeff()).normalized();
    implicit_params.contact_offset = 0.5 * m.thickness;
    self_contact.gap = scenario.sim.self_contact.gap;
    self_contact.friction = scenario.sim.self_contact.friction;
    self_contact.repulsions = false;  // the implicit step keeps the pairs apart (find_self_pairs)
    implicit_params.self_gap = self_contact.gap;
    implicit_params.self_friction = self_contact.friction;
    self_contact.dt = implicit_params.dt;
    self_contact.run = implicit_params.run;
    membrane = membrane_params(m);
    take_propagation_params(m);
    tear_direction_from_name(scenario.tearing.direction, tearing_params.direction);  // validated
    tearing_params.membrane = membrane;
    relaxation = scenario.sim.relaxation == "next_frame" ? Relaxation::NextFrame
                 : scenario.sim.relaxation == "patch"    ? Relaxation::Patch  // validated: implicit solver only
                                                         : Relaxation::Substep;
    tearing_params.relaxation =
        relaxation == Relaxation::NextFrame ? TearRelaxation::NextFrame : TearRelaxation::AfterEachCut;
    tearing_params.check_invariants = options.check_invariants;
    local_relaxation.radius = scenario.sim.relaxation_radius;
    tearing_params.driving_force_radius = scenario.tearing.radius;
    tearing_params.rays.driving_force_radius = scenario.tearing.radius;
    tearing_params.quasi_static = tearing_params.direction == TearDirection::TensionRays;
    tearing_params.remesh.snap_fraction = scenario.tearing.snap_fraction();
    tearing_params.shielding_radius = scenario.tearing.shielding_radius;
    tearing_params.max_tip_turn = scenario.tearing.max_turn_deg * std::numbers::pi / 180.0;
    tearing_params.rays.start_wrap = scenario.tearing.start_wrap;
    tearing_params.rays.start_length = scenario.tearing.start_length;
    tearing_params.rays.edge_radius = scenario.tearing.edge_radius;
    tearing_params.rays.rays.bearing_length = scenario.tearing.bearing_length;
    tearing_params.rays.rays.opening_floor = scenario.tearing.opening_floor;

    update_finger_targets(0.0, sheet.hands, sheet.fingers);
    for (Finger& f : sheet.fingers) f.reaction.setZero();
    // A flow graph spawns its tasks in the arena it was made in: make it inside the sheet's own arena,
    // or a sheet created by a batch worker would queue its nodes in the batch's arena and wait forever.
    arena.execute([&] { build_graph(); });
  }

  // Kernels split [0, count) into fixed ranges of `grain`; each range writes its own outputs, so the
  // result is the same whichever thread runs which range (docs/architecture.md "The frame", determinism).
  void run_ranges(int32_t count, int32_t grain, const RangeTask& task) const {
    if (count <= 0) return;
    if (options.threads <= 1 || count <= grain) {
      task(0, count);
      return;
    }
    tbb::parallel_for(
        tbb::blocked_range<int32_t>(0, count, std::max(1, grain)),
        [&](const tbb::blocked_range<int32_t>& r) { task(r.begin(), r.end()); }, tbb::simple_partitioner());
  }

  double time_at(int32_t f) const { return f / scenario.sim.fps; }

  // Finger i's target at fraction alpha of the frame's motion, and the point its pinch holds (the target
  // plus how far the paper has slid through it).
  Vec3 target_at(size_t i, double alpha) const {
    return (1 - alpha) * targets_begin[i] + alpha * sheet.fingers[i].target;
  }
  Vec3 hold_point(size_t i, double alpha) const { return target_at(i, alpha) + sheet.fingers[i].hold_offset; }
  // The rotation finger i's pad turns with at fraction alpha of the frame's motion.
  Mat3 rotation_at(size_t i, double alpha) const {
    return finger_rotation(sheet.hands, sheet.fingers[i], (1 - alpha) * time_at(frame) + alpha * time_at(frame + 1));
  }

  void held_vertices(double alpha, std::vector<int32_t>& held, std::vector<Vec3>& target) const {
    held.clear();
    target.clear();
    for (size_t i = 0; i < sheet.fingers.size(); ++i) {
      const Finger& f = sheet.fingers[i];
      if (f.vertex < 0) continue;
      if (f.slipping) continue;  // pulls through its pinch's spring instead (systems/physics/grip.hpp)
      const Vec3 centre = hold_point(i, alpha);
      held.push_back(f.vertex);
      target.push_back(centre);
      if (f.pad.empty()) continue;
      const Mat3 rotation = rotation_at(i, alpha);
      for (size_t j = 0; j < f.pad.size(); ++j) {
        held.push_back(f.pad[j]);
        target.push_back(centre + rotation * f.pad_offset[j]);
      }
    }
  }

  // --- systems as run by the graph -------------------------------------------------------------------

  // Fingers put on the sheet or let go at this frame's start (attach/release times of the scenario or
  // of an interactive session).
  void attach_and_release(double t) {
    bool changed = false;
    for (Finger& f : sheet.fingers) {
      if (!f.released && f.vertex < 0 && f.attach_time <= t) {
        f.vertex = insert_pattern_vertex(f.uv, InsertParams{}, sheet);
        if (f.vertex < 0) {
          f.released = true;  // uv no longer on the sheet (torn away): the finger grabs nothing
          continue;
        }
        f.start = sheet.verts.x[f.vertex];
        if (f.keys.empty()) f.target = f.start;  // hold the sheet where it was grabbed
        if (f.hand >= 0) hand_centroid_of_starts(sheet.fingers, sheet.hands[f.hand]);
        grab_pad(sheet.verts, sheet.hands, t, static_cast<size_t>(&f - sheet.fingers.data()), sheet.fingers);
        changed = true;
      }
      if (f.vertex >= 0 && f.release_time <= t) {
        release(f);
        changed = true;
      }
    }
    if (changed) refresh_role_flags();
  }

  void run_fingers() {
    ScopedTimer timer(profile.fingers);
    attach_and_release(time_at(frame));
    targets_begin.clear();
    for (const Finger& f : sheet.fingers) targets_begin.push_back(f.target);
    regrip_at(0);
    update_finger_targets(time_at(frame + 1), sheet.hands, sheet.fingers);
  }

  // What a substep does with the fingers' reactions, which it reads on the state it started from.
  enum class Reactions {
    Grip,  // a finger past its grip slips now
    Read,  // only read: the frame is about to stop for the tearing step, which may relieve them
    Skip,  // not read: the state is a fresh cut, not a state of the sheet's motion (relax_after_cut reads
           // the relaxed one)
  };
  // Triangles::pinched from the fingers as they hold now, before anything computes membrane forces. It
  // depends only on the topology and on which vertex each finger holds with which pad, so it is rebuilt
  // only when one of those changed (a substep's forces, its stop bisection and the relaxation all ask).
  struct PinchKey {
    uint64_t topology = ~uint64_t{0};
    size_t triangles = 0;
    std::vector<std::pair<int32_t, double>> holds;  // per finger: vertex, pad radius
    bool operator==(const PinchKey&) const = default;
  };
  PinchKey pinch_key, pinch_probe;
  void mark_pinched() {
    pinch_probe.topology = sheet.topology_version;
    pinch_probe.triangles = sheet.tris.tri.size();
    pinch_probe.holds.clear();
    for (const Finger& f : sheet.fingers) pinch_probe.holds.emplace_back(f.vertex, f.pad_radius);
    if (pinch_probe == pinch_key && sheet.tris.pinched.size() == sheet.tris.tri.size()) return;
    mark_pinched_triangles(sheet.fingers, sheet.verts.rest, sheet.tris.tri, sheet.topo, kFingertipRadius,
                           sheet.tris.pinched);
    std::swap(pinch_key, pinch_probe);
  }

  void substep(double alpha, Reactions reactions = Reactions::Grip) {
    mark_pinched();
    std::vector<int32_t> held;
    std::vector<Vec3> target;
    held_vertices(alpha, held, target);
    hold_points.clear();
    for (size_t i = 0; i < sheet.fingers.size(); ++i) hold_points.push_back(hold_point(i, alpha));
    slipping_pinches(sheet.verts, sheet.fingers, hold_points, kPinchStiffness, implicit_params.springs);
    // verts.force now holds the internal forces of the state this substep started from: the fingers'
    // reactions during it.
    if (scenario.sim.self_contact.on) find_self_pairs(held, target);
    const bool stepped = implicit_substep(implicit_params, held, target, implicit, sheet);
    implicit_params.self_pairs = nullptr;  // this sheet's, for this step only (the patch relaxation has its own)
    if (!stepped) return;
    if (scenario.sim.self_contact.on) resolve_substep_self_contact(held);
    if (substep_observer) substep_observer(sheet);
    if (reactions == Reactions::Grip)
      check_grip(sheet.verts, scenario.sim.gravity, sheet.fingers);
    else if (reactions == Reactions::Read)
      read_reactions(sheet.verts, scenario.sim.gravity, sheet.fingers);
  }

  // The pairs the implicit step keeps apart in its solve: those near at the substep's start or on the
  // paths it predicts (free vertices moving on at their velocity, held ones to their targets).
  void find_self_pairs(const std::vector<int32_t>& held, const std::vector<Vec3>& target) {
    const Vertices& V = sheet.verts;
    self_contact_start = V.x;
    self_contact_predicted.resize(V.x.size());
    for (size_t i = 0; i < V.x.size(); ++i) self_contact_predicted[i] = V.x[i] + implicit_params.dt * V.v[i];
    for (size_t k = 0; k < held.size(); ++k) self_contact_predicted[held[k]] = target[k];
    self_contact_stats += self_contact_proximities(self_contact, sheet.tris.tri, V.rest, V.x, self_contact_predicted,
                                                   self_contact_broad, self_pairs);
    implicit_params.self_pairs = &self_pairs;
  }

  // The substep's motion from self_contact_start to x made free of self-intersections (held vertices keep
  // their prescribed paths). Positions and velocities only: verts.force and the corner forces, which the
  // tearing criteria and the fingers' reactions read, are the implicit step's.
  void resolve_substep_self_contact(const std::vector<int32_t>& held) {
    const Vertices& V = sheet.verts;
    self_contact_inverse_mass.resize(V.mass.size());
    for (size_t i = 0; i < V.mass.size(); ++i) self_contact_inverse_mass[i] = V.mass[i] > 0 ? 1 / V.mass[i] : 0;
    for (int32_t h : held) self_contact_inverse_mass[h] = 0;
    // A vertex resting on an obstacle (within a twentieth of the gap of its grown surface; a layer lying on
    // it is a gap higher) is as immovable as the obstacle: an impulse pushing it into a table would leave
    // it inside until the next solve, which then throws the layers apart (measured: fold-half's bottom
    // layer bounced at up to 6 m/s and the fold tore).
    for (const Obstacle& o : implicit_params.obstacles)
      for (size_t i = 0; i < V.x.size(); ++i)
        if (obstacle_distance(o, V.x[i]) < implicit_params.contact_offset + 0.05 * self_contact.gap)
          self_contact_inverse_mass[i] = 0;
    self_contact_stats +=
        resolve_self_contact(self_contact, sheet.tris.tri, V.rest, self_contact_start, self_contact_inverse_mass,
                             self_contact_broad, sheet.verts.x, sheet.verts.v);
  }

  // Quasi-static tearing at the substeps' pace: the frame's physics stops at the first substep after which
  // a finger holds more than its grip or the tearing step would cut (a tip advances or a tear starts), the
  // tearing step runs on that state, and the frame's remaining substeps follow it (resume_substep), each
  // again stopping where the next cut is due. Fingers do not out-run the tear: between two substeps a taut
  // strip's pull grows by up to a few newtons, so substeps that ran on unchecked after a start held the
  // fingers past 5 N (docs/tearing.md "Quasi-static tearing").
  bool stops_for_tearing() const {
    return tearing_params.direction == TearDirection::TensionRays &&
           tearing_params.relaxation == TearRelaxation::AfterEachCut;
  }

  // Substeps first..n of the frame; returns true when it stopped for tearing (resume_substep set).
  bool run_substeps_from(int32_t first) {
    const int32_t n = scenario.sim.substeps;
    resume_substep = -1;
    physics_alpha = 1.0;
    const bool may_stop = stops_for_tearing();
    for (int32_t s = first; s <= n; ++s) {
      if (!may_stop) {
        substep(static_cast<double>(s) / n, Reactions::Grip);
        continue;
      }
      save_substep_start();
      substep(static_cast<double>(s) / n, Reactions::Read);
      // The substep left the reactions of the state it started from; the stop reads the state it reached,
      // else a start is cut one substep late, on a strip whose pull has grown meanwhile. The frame's last
      // substep stops too, else a start due in it was read at its end; it is then run once more from the
      // state the tearing step left, so the frame still ends with the fingers at their targets. A finger
      // past its grip slips at the frame's last substep, when no cut is due there.
      const bool due = stop_due();
      // Due without a finger past its grip means a cut is due: the rays are asked again only otherwise.
      const bool tear_due = due && (!grip_exceeded(sheet.fingers) || tear_due_now());
      if (!due || (s == n && (last_substep_rerun || !tear_due))) {
        if (s == n) check_grip(sheet.verts, scenario.sim.gravity, sheet.fingers);
        else read_reactions(sheet.verts, scenario.sim.gravity, sheet.fingers);
        continue;
      }
      last_substep_rerun = s == n;
      resume_substep = s == n ? n : s + 1;
      physics_alpha = refine_stop(static_cast<double>(s - 1) / n, static_cast<double>(s) / n);
      read_reactions(sheet.verts, scenario.sim.gravity, sheet.fingers);
      return true;
    }
    return false;
  }

  // Whether the state a substep reached is one the frame's physics stops at: a finger past its grip, or a
  // cut the tearing step would make. Leaves that state's forces and reactions (not yet in max_force).
  bool stop_due() {
    internal_forces();
    read_transient_reactions(sheet.verts, scenario.sim.gravity, sheet.fingers);
    return grip_exceeded(sheet.fingers) || tear_due_now();
  }
  // Whether the tearing step would cut on the current state (stop_due read its forces and reactions).
  bool tear_due_now() { return tension_rays_would_tear(tearing_params, candidates, sheet, tearing_scratch); }

  // A substep over which a taut strip's pull jumped (a start at the strain limit: 1.9 → 5.5 N in one of
  // start-finger's substeps) stops where Griffith's criterion was already passed partway through it. An
  // implicit Euler substep moves every vertex along a straight line, x + τ h v⁺ for τ ∈ [0, 1], the held
  // ones included, so the states it passed through are known without another solve: bisect τ between the
  // state the substep started from (stop_before) and the one it reached, until the fingers' reactions
  // differ by at most kStopForceResolution across the bracket, and leave the earliest stopping state found.
  // Returns its finger-motion fraction between `before` and `after`.
  static constexpr double kStopForceResolution = 0.02;  // N
  static constexpr int kMaxStopRefinements = 8;
  double refine_stop(double before, double after) {
    std::vector<Vec3>& x = sheet.verts.x;
    stop_end = x;    // τ = 1: the bisection's states lie on the line from stop_before.x to it
    stop_after = x;  // the earliest stopping state found
    std::vector<Finger> reacted_before = stop_before.fingers;  // the fingers at the bracket's ends
    std::vector<Finger> reacted_after = sheet.fingers;
    double lo = 0, hi = 1;
    bool forces_of_after = true;  // verts.force is of stop_after's state
    for (int level = 0; level < kMaxStopRefinements && reaction_jump(reacted_before, reacted_after) > kStopForceResolution;
         ++level) {
      const double mid = 0.5 * (lo + hi);
      for (size_t i = 0; i < x.size(); ++i) x[i] = stop_before.x[i] + mid * (stop_end[i] - stop_before.x[i]);
      forces_of_after = stop_due();
      if (forces_of_after) {
        hi = mid;
        stop_after = x;
        reacted_after = sheet.fingers;
      } else {
        lo = mid;
        reacted_before = sheet.fingers;
      }
    }
    x = stop_after;
    sheet.fingers = reacted_after;
    if (!forces_of_after) internal_forces();
    return before + hi * (after - before);
  }

  // The largest change of a holding finger's reaction between two readings, N.
  static double reaction_jump(const std::vector<Finger>& earlier, const std::vector<Finger>& later) {
    double jump = 0;
    for (size_t i = 0; i < later.size(); ++i)
      if (later[i].vertex >= 0) jump = std::max(jump, (later[i].reaction - earlier[i].reaction).norm());
    return jump;
  }

  // The state a substep starts from, for the stop's bisection.
  struct SubstepStart {
    std::vector<Vec3> x;
    std::vector<Finger> fingers;
  };
  SubstepStart stop_before;
  std::vector<Vec3> stop_end, stop_after;
  void save_substep_start() {
    stop_before.x = sheet.verts.x;
    stop_before.fingers = sheet.fingers;
  }

  void run_physics() {
    ScopedTimer timer(profile.integrate);
    last_substep_rerun = false;
    run_substeps_from(1);
  }

  // Membrane corner forces (kept for clustering), per-vertex sums and bending.
  void internal_forces() {
    Vertices& V = sheet.verts;
    Triangles& T = sheet.tris;
    if (bending_version != sheet.topology_version) {
      build_bending_stencils(V.rest, sheet.topo.hinges, bending_stiffness(sheet.material), bending);
      bending_version = sheet.topology_version;
    }
    mark_pinched();
    run_ranges(T.size(), options.parallel_grain, [&](int32_t b, int32_t e) {
      compute_membrane_forces(V.x, T.tri, T.rest_inv, T.rest_area, T.pinched, membrane, b, e, T.corner_force);
    });
    run_ranges(V.size(), options.parallel_grain, [&](int32_t b, int32_t e) {
      gather_corner_forces(sheet.topo, T.tri, T.corner_force, b, e, V.force);
    });
    add_bending_forces(V.x, bending, V.force);
  }

  // The internal forces, then the finger reactions. `of_the_motion`: the state is one of the sheet's motion
  // (a frame's end, or where its physics stopped for tearing), not the one relaxation substep after a cut,
  // whose lips are still snapping open; only those count for the run's max_strain.
  void compute_forces(bool of_the_motion = true) {
    Vertices& V = sheet.verts;
    Triangles& T = sheet.tris;
    internal_forces();
    // The run's largest principal strain (result.json "max_strain"): per triangle in the ranges (each
    // writes its own slots), the max taken serially.
    if (of_the_motion) {
      triangle_strain.resize(T.size());
      run_ranges(T.size(), options.parallel_grain, [&](int32_t b, int32_t e) {
        for (int32_t t = b; t < e; ++t) triangle_strain[t] = max_principal_strain(V.x, T.tri, T.rest_inv, t, t + 1);
      });
      for (int32_t t = 0; t < T.size(); ++t) {
        max_strain = std::max(max_strain, triangle_strain[t]);
        if (triangle_strain[t] > max_strain_beyond_tips && beyond_tips(t)) max_strain_beyond_tips = triangle_strain[t];
      }
    }
    // A held vertex is in quasi-static balance: the finger supplies what the sheet and gravity do not.
    for (size_t i = 0; i < sheet.fingers.size(); ++i) {
      Finger& f = sheet.fingers[i];
      if (f.vertex < 0) f.reaction.setZero();
      else if (f.slipping) f.reaction = slipping_pinch_force(V, f, hold_point(i, physics_alpha), kPinchStiffness);
    }
    if (of_the_motion) check_grip(V, scenario.sim.gravity, sheet.fingers);
    else read_transient_reactions(V, scenario.sim.gravity, sheet.fingers);
  }

  // A crack tip's strain is singular in linear elasticity and, in paper, spread over a process zone of
  // pulled-out fibres a few millimetres long: a triangle at the tip reads more the smaller it is, and a
  // triangle that reaches into the zone averages the singular field however far its centroid is (on
  // coarse meshes 10-17 mm triangles with a corner at the tip). So the sheet's own stretch is read on the
  // triangles that come no nearer than kTipZone (pattern) to an active tip or to an inward corner of the
  // outline that no tear has started from (a notch's end: a crack tip that has not moved yet).
  static constexpr double kTipZone = 0.005;  // m
  static constexpr double kCornerTorn = 0.001;  // m: a tear started this near a corner started from it
  std::vector<Vec2> outline_corners;  // the rest pattern's inward corners as built
  bool beyond_tips(int32_t t) const {
    const Tri& c = sheet.tris.tri[t];
    const std::vector<Vec2>& r = sheet.verts.rest;
    auto near = [&](const Vec2& p) { return point_triangle_distance(p, r[c[0]], r[c[1]], r[c[2]]) < kTipZone; };
    for (const Tip& tip : sheet.tips)
      if (near(r[tip.vertex])) return false;
    for (const Vec2& corner : outline_corners) {
      if (!near(corner)) continue;
      bool torn = false;
      for (const Tear& tear : sheet.tears) torn = torn || (tear.start_uv - corner).norm() < kCornerTorn;
      if (!torn) return false;
    }
    return true;
  }

  void run_forces() {
    ScopedTimer timer(profile.forces);
    compute_forces();
  }

  void run_regions() {
    ScopedTimer timer(profile.regions);
    region_summary = classify_regions(sheet.verts.x, sheet.tris.tri, sheet.topo, region_params, sheet.tris.region,
                                      sheet.regions, sheet.verts.flags);
  }

  void run_candidates() {
    ScopedTimer timer(profile.candidates);
    find_candidates(sheet.verts, sheet.topo.boundary_vertices, sheet.tips, sheet.fingers, sheet.tears,
                    sheet.material, fiber, candidates, fiber_cache);
  }

  // Slipping fingers hold again at fraction alpha of the frame's motion (systems/physics/grip.hpp).
  void regrip_at(double alpha) {
    hold_points.clear();
    pad_rotations.clear();
    for (size_t i = 0; i < sheet.fingers.size(); ++i) {
      hold_points.push_back(target_at(i, alpha));
      pad_rotations.push_back(rotation_at(i, alpha));
    }
    if (regrip_slipping_fingers(sheet.verts, hold_points, pad_rotations, sheet.fingers)) refresh_role_flags();
  }

  void refresh_role_flags() { pt::refresh_role_flags(sheet.fingers, sheet.tips, sheet.verts.flags); }

  // Fig. 4 step 4 after a cut: an extra substep of the whole sheet or a substep of the patch around the
  // tear's path, then the forces of the relaxed state for the next point's clustering. The fingers stay
  // where the physics stopped (physics_alpha): the relaxation lets the lips open, it does not move the hands.
  void relax_after_cut(int32_t tear_id) {
    // A slipping finger holds again where it is: the cut may have relieved the pull that made it slip.
    regrip_at(physics_alpha);
    if (relaxation == Relaxation::Patch) {
      mark_pinched();
      std::vector<int32_t> held;
      std::vector<Vec3> target;
      held_vertices(physics_alpha, held, target);
      if (!relax_patch_after_cut(implicit_params, local_relaxation, sheet.tears[tear_id].tips, held, target,
                                 local_scratch, sheet)
               .relaxed)
        ++patch_failures;
    } else {
      substep(physics_alpha, Reactions::Skip);
    }
    compute_forces(false);
  }

  // Paper Fig. 4 steps 2–4 for each potential tearing point in turn (systems/tearing/tearing_step.hpp),
  // at every stop of the frame's physics: after each tearing step the frame's remaining substeps run until
  // the next stop, whose state gets the graph's forces, regions and candidates and its own tearing step.
  void run_tearing() {
    run_tearing_once();
    while (resume_substep >= 0) {
      bool stopped;
      {
        ScopedTimer timer(profile.integrate);
        stopped = run_substeps_from(resume_substep);
      }
      run_forces();
      if (!stopped) return;
      run_regions();
      run_candidates();
      run_tearing_once();
    }
  }

  void run_tearing_once() {
    TearingHooks hooks;
    hooks.relax = [this](int32_t tear_id) { relax_after_cut(tear_id); };
    hooks.update_forces = [this] { run_forces(); };
    hooks.list_candidates = [this] { run_candidates(); };
    TearingTimes times;
    run_tearing_step(tearing_params, hooks, candidates, frame, sheet, tearing_log, times, tearing_scratch);
    profile.clustering += times.clustering;
    profile.propagation += times.propagation;
    profile.remeshing += times.remeshing;
    profile.relaxation += times.relaxation;
  }

  void run_carving() {
    ScopedTimer timer(profile.carving);
    carve_new_segments(fiber, detail, sheet.tears, carve_state);
  }

  // --- the graph --------------------------------------------------------------------------------------

  // A node of the graph; its body is also kept in systems_in_order (run_frame_in_order), so each node must
  // be created after the nodes it has edges from.
  tbb::flow::continue_node<tbb::flow::continue_msg>& node(std::function<void()> body) {
    systems_in_order.push_back(body);
    nodes.push_back(std::make_unique<tbb::flow::continue_node<tbb::flow::continue_msg>>(
        *graph, [body = std::move(body)](const tbb::flow::continue_msg&) { body(); }));
    return *nodes.back();
  }

  void build_graph() {
    using tbb::flow::make_edge;
    graph = std::make_unique<tbb::flow::graph>();
    start = std::make_unique<tbb::flow::broadcast_node<tbb::flow::continue_msg>>(*graph);
    auto& fingers = node([this] { run_fingers(); });
    auto& carving = node([this] { run_carving(); });
    auto& physics = node([this] { run_physics(); });
    auto& forces = node([this] { run_forces(); });
    auto& regions = node([this] { run_regions(); });
    auto& cands = node([this] { run_candidates(); });
    auto& tearing = node([this] { run_tearing(); });
    make_edge(*start, fingers);
    make_edge(fingers, physics);   // substeps interpolate towards the frame's finger targets
    make_edge(physics, forces);    // forces of the state the frame ends in, read by clustering
    make_edge(forces, regions);    // depends on: x after integration (regions read dihedral angles)
    make_edge(regions, cands);     // junction points come from the regions
    make_edge(cands, tearing);     // the potential tearing points, in order
    // Carving reads the tips of segments cut in earlier frames, which nothing above changes; it runs
    // beside the physics and must end before tearing appends new tips (tearing has two predecessors).
    make_edge(*start, carving);
    make_edge(carving, tearing);
  }

  // The graph's systems in one of its orders (their creation order), on the calling thread. A sheet no
  // larger than one range of the kernels (parallel_grain) runs its frame this way: its kernels run serially
  // anyway, and the graph only moved its systems between the cores — the cut then found the sheet in the
  // other core's cache (bench/results/2026-11-23-10-notes.txt §8). Same systems,
  // same order of their effects on the sheet (carving reads only tips cut in earlier frames), so the same
  // results.
  void run_frame_in_order() {
    for (const std::function<void()>& system : systems_in_order) system();
  }

  void step() {
    if (!stop_reason.empty()) return;
    profile = FrameProfile{};
    const auto t0 = Clock::now();
    arena.execute([&] {
      if (sheet.tris.size() <= options.parallel_grain) {
        run_frame_in_order();
        return;
      }
      start->try_put(tbb::flow::continue_msg());
      graph->wait_for_all();
    });
    ++frame;
    profile.frame = ms_since(t0);
    timings.add(profile);
    stats.push_back(FrameStats{sheet.tris.size(), region_summary.regions, region_summary.junctions,
                               static_cast<int32_t>(candidates.size())});
    check_position_bound();
  }

  // Far from the origin doubles no longer resolve the sheet's strains (engine/scenario.hpp): the run stops
  // rather than tear the sheet apart by rounding. A NaN is left to the result's finite-number check.
  void check_position_bound() {
    for (int32_t v = 0; v < sheet.verts.size(); ++v) {
      const Vec3& x = sheet.verts.x[v];
      if (!(x.cwiseAbs().maxCoeff() > kMaxSheetPosition)) continue;
      char buf[160];
      std::snprintf(buf, sizeof buf, "vertex %d left the +-%g m bound of positions at frame %d (at (%.3g, %.3g, %.3g) m)",
                    v, kMaxSheetPosition, frame, x.x(), x.y(), x.z());
      stop_reason = buf;
      return;
    }
  }
};

// Scenarios built in code (viewer, embedding, batches) get the same checks as files: a reversed key or a
// NaN target would otherwise run (issue 9, tests/engine/hostile_test.cpp).
namespace {

const EngineOptions& checked_options(const EngineOptions& options) {
  if (options.threads < 1 || options.threads > kMaxThreads)
    throw InputError("threads: must be 1 to " + std::to_string(kMaxThreads) + ", got " +
                     std::to_string(options.threads));
  return options;
}

}  // namespace

Simulation::Simulation(const Scenario& scenario, const EngineOptions& options)
    : impl_((validate_scenario(scenario), std::make_unique<Impl>(scenario, checked_options(options)))) {}
Simulation::~Simulation() = default;

void Simulation::step() { impl_->step(); }
void Simulation::flush() {
  impl_->arena.execute([&] { carve_new_segments(impl_->fiber, impl_->detail, impl_->sheet.tears, impl_->carve_state); });
}
int32_t Simulation::frame() const { return impl_->frame; }
const std::string& Simulation::stop_reason() const { return impl_->stop_reason; }
double Simulation::time() const { return impl_->time_at(impl_->frame); }
const Sheet& Simulation::sheet() const { return impl_->sheet; }
const Scenario& Simulation::scenario() const { return impl_->scenario; }
const FrameProfile& Simulation::last_profile() const { return impl_->profile; }
const TimingReport& Simulation::timings() const { return impl_->timings; }
const std::vector<FrameStats>& Simulation::frame_stats() const { return impl_->stats; }
const std::vector<TearEvent>& Simulation::events() const { return impl_->tearing_log.events; }
const std::vector<std::string>& Simulation::invariant_violations() const { return impl_->tearing_log.violations; }
int32_t Simulation::remesh_count() const { return impl_->tearing_log.remeshes; }
double Simulation::max_strain() const { return impl_->max_strain; }
double Simulation::max_strain_beyond_tips() const { return impl_->max_strain_beyond_tips; }
size_t Simulation::solver_bytes() const { return impl_->implicit ? implicit_solver_bytes(*impl_->implicit) : 0; }
int32_t Simulation::threads() const { return impl_->options.threads; }

ThreadCount usable_threads(int32_t asked) {
  return {asked, std::min(asked, std::max(1, static_cast<int32_t>(tbb::info::default_concurrency())))};
}

std::string threads_cap_note(const ThreadCount& t, const std::string& option) {
  if (t.used >= t.asked) return "";
  return option + std::to_string(t.asked) + " capped at the " + std::to_string(t.used) +
         (t.used == 1 ? " CPU" : " CPUs") + " available";
}
std::string Simulation::state_hash() const { return hash_sheet(impl_->sheet); }
int32_t Simulation::attach_finger(const std::string& name, const Vec2& uv) {
  Impl& m = *impl_;
  const int32_t v = insert_pattern_vertex(uv, InsertParams{}, m.sheet);
  if (v < 0) return -1;
  Finger f;
  f.name = name;
  f.uv = uv;  // as asked: a replay inserts at the same point and so meets the same snapping
  f.vertex = v;
  f.attach_time = time();
  f.start = m.sheet.verts.x[v];
  f.target = f.start;
  f.keys.push_back(FingerKey{f.attach_time, f.start});
  m.sheet.fingers.push_back(f);
  m.refresh_role_flags();
  return static_cast<int32_t>(m.sheet.fingers.size()) - 1;
}

void Simulation::move_finger(int32_t finger, const Vec3& target) {
  Finger& f = finger_of(impl_->sheet, finger, "move_finger");
  const std::string which = "move_finger: finger " + std::to_string(finger) + " (" + f.name + "): target ";
  if (!target.allFinite()) throw InputError(which + fmt_point(target) + " is not a finite point");
  if (target.cwiseAbs().maxCoeff() > kMaxTarget)
    throw InputError(which + fmt_point(target) + " is too far (each coordinate at most 1000 m)");
  if (f.released) return;  // let go (or slid out of its pinch): it holds nothing to move
  const double t = impl_->time_at(impl_->frame + 1);
  if (!f.keys.empty() && f.keys.back().t >= t) f.keys.back().position = target;
  else f.keys.push_back(FingerKey{t, target});
}

void Simulation::set_propagation_speed(double speed, double max_step) {
  if (!(speed >= 0) || !(max_step > 0) || !std::isfinite(speed) || !std::isfinite(max_step))
    throw std::invalid_argument("propagation speed must be >= 0 and the step cap > 0, both finite");
  Impl& m = *impl_;
  m.sheet.material.speed = speed;
  m.sheet.material.max_step = max_step;
  m.take_propagation_params(m.sheet.material);
}

void Simulation::set_detail_noise(double sigma, double omega) {
  if (!(sigma >= 0) || !std::isfinite(sigma) || !(omega >= 0 && omega <= 1))
    throw std::invalid_argument("detail sigma must be >= 0 and finite, omega in [0, 1]");
  impl_->detail.sigma = sigma;
  impl_->detail.omega = omega;
}

void Simulation::release_finger(int32_t finger) {
  Finger& f = finger_of(impl_->sheet, finger, "release_finger");
  f.release_time = time();
  release(f);
  impl_->refresh_role_flags();
}

void Simulation::notify_topology_changed() {
  refresh_after_topology_change(impl_->sheet);
  impl_->refresh_role_flags();
}

// engine/simulation_internals.hpp: the one way in to Impl from outside the class.
struct SimulationInternals {
  static Simulation::Impl& of(const Simulation& sim) { return *sim.impl_; }
};

const FiberField& fiber_field(const Simulation& sim) { return SimulationInternals::of(sim).fiber; }
const DetailParams& detail_params(const Simulation& sim) { return SimulationInternals::of(sim).detail; }
const CarveState& carve_state(const Simulation& sim) { return SimulationInternals::of(sim).carve_state; }
const std::vector<Candidate>& tearing_candidates(const Simulation& sim) { return SimulationInternals::of(sim).candidates; }
ImplicitStats solver_stats(const Simulation& sim) {
  const auto& m = SimulationInternals::of(sim);
  ImplicitStats stats = m.implicit ? implicit_solver_stats(*m.implicit) : ImplicitStats{};
  stats.failures += m.patch_failures;  // a refused patch relaxation left its lips where they were
  return stats;
}
Sheet& mutable_sheet(Simulation& sim) { return SimulationInternals::of(sim).sheet; }
const SelfContactStats* self_contact_stats(const Simulation& sim) {
  const auto& m = SimulationInternals::of(sim);
  return m.scenario.sim.self_contact.on ? &m.self_contact_stats : nullptr;
}
void set_substep_observer(Simulation& sim, std::function<void(const Sheet&)> observer) {
  SimulationInternals::of(sim).substep_observer = std::move(observer);
}

}  // namespace pt
