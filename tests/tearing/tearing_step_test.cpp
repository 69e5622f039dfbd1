// The tearing step (paper Fig. 4 steps 2–4) as free functions: crack shielding, the tip's turn limit, the
// tear bookkeeping after a cut, the frame's propagation budget, and whole steps on a small notched grid
// under a hand-made load, with hooks in place of the engine's relaxation and candidate listing.
#include "systems/tearing/tearing_step.hpp"
#include "systems/common/topology.hpp"

#include "tests/test_meshes.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

using namespace pt;

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kSize = 0.2;  // m, the grid's width and height
constexpr int kCells = 10;     // cells per side: 2 cm

Vec2 at_angle(double deg) { return Vec2(std::cos(deg * kPi / 180), std::sin(deg * kPi / 180)); }

// A flat 20 x 20 cm grid whose top-middle vertex is pushed down by half a cell: a notch opening upwards.
int32_t notch_vertex() { return kCells * (kCells + 1) + kCells / 2; }

Sheet notched_sheet() {
  Sheet s = test::grid_sheet(kSize, kSize, kCells, kCells);
  const int32_t p = notch_vertex();
  s.verts.rest[p].y() -= 0.5 * kSize / kCells;
  s.verts.x[p] = Vec3(s.verts.rest[p].x(), s.verts.rest[p].y(), 0);
  refresh_after_topology_change(s);
  return s;
}

// A mode I opening at p: every triangle of p's fan pulls p up and away from its own side (left triangles
// to the upper left, right ones to the upper right), `magnitude` N each. The clusters' bisector points up,
// so t points straight down into the sheet. Every other corner force is left as it is.
void load_opening(int32_t p, double magnitude, Sheet& s) {
  for (int32_t t = 0; t < s.tris.size(); ++t)
    for (int i = 0; i < 3; ++i) {
      if (s.tris.tri[t][i] != p) continue;
      Vec2 centroid = Vec2::Zero();
      for (int k = 0; k < 3; ++k) centroid += s.verts.rest[s.tris.tri[t][k]] / 3.0;
      const double side = centroid.x() < s.verts.rest[p].x() ? -1.0 : 1.0;
      s.tris.corner_force[t][i] = magnitude * Vec3(side, 1, 0).normalized();
    }
}

void clear_forces(Sheet& s) {
  for (auto& corners : s.tris.corner_force) corners = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
}

// Steps of a fixed length (speed so large that max_step caps them) and invariants checked after each cut.
TearingParams step_params(double step = 0.03) {
  TearingParams p;
  p.propagation.thickness = 1e-4;
  p.propagation.speed = 1.0;
  p.propagation.max_step = step;
  p.check_invariants = true;
  return p;
}

Candidate candidate(int32_t vertex, StartKind kind = StartKind::Inward, int32_t tear = -1) {
  return Candidate{vertex, kind, tear, 1.0};  // Ef = 1 J/m²: far below what the loads release
}

// Hooks that count their calls. relax clears the load, so nothing propagates after it unless
// list_candidates loads again.
struct CountingHooks {
  int relaxed = 0, forces = 0, listed = 0;
  std::vector<int32_t> relaxed_tears;
  std::function<void()> list = [] {};
  TearingHooks hooks(Sheet& s) {
    TearingHooks h;
    h.relax = [this, &s](int32_t tear) {
      ++relaxed;
      relaxed_tears.push_back(tear);
      clear_forces(s);
    };
    h.update_forces = [this] { ++forces; };
    h.list_candidates = [this] {
      ++listed;
      list();
    };
    return h;
  }
};

// The top edge's boundary vertices but its two corners, in boundary order.
std::vector<int32_t> top_edge_vertices(const Sheet& s) {
  std::vector<int32_t> top;
  for (int32_t v : s.topo.boundary_vertices) {
    const Vec2& r = s.verts.rest[v];
    if (r.y() > kSize - 1e-12 && r.x() > 1e-12 && r.x() < kSize - 1e-12) top.push_back(v);
  }
  return top;
}

// The top edge's vertices but its corners as finger starts, each loaded with a mode I opening: the
// candidates of the budget and start tests, listed again after every cut (ids change).
void list_loaded_top_edge(Sheet& s, std::vector<Candidate>& candidates) {
  candidates.clear();
  for (int32_t v : top_edge_vertices(s)) {
    candidates.push_back(candidate(v, StartKind::Finger));
    load_opening(v, 1.0, s);
  }
}

// The buffers a tearing step writes (its log, times and scratch), kept between the steps of a test.
struct Step {
  TearingLog log;
  TearingTimes times;
  TearingScratch scratch;
  void run(const TearingParams& params, const TearingHooks& hooks, const std::vector<Candidate>& candidates,
           int32_t frame, Sheet& s) {
    run_tearing_step(params, hooks, candidates, frame, s, log, times, scratch);
  }
};

}  // namespace

TEST(TearingStep, DirectionNames) {
  TearDirection d = TearDirection::MaterialForce;
  ASSERT_TRUE(tear_direction_from_name("bisector", d));
  EXPECT_EQ(d, TearDirection::Fan);
  d = TearDirection::MaterialForce;
  ASSERT_TRUE(tear_direction_from_name("fan", d));
  EXPECT_EQ(d, TearDirection::Fan);
  ASSERT_TRUE(tear_direction_from_name("material_force", d));
  EXPECT_EQ(d, TearDirection::MaterialForce);
  EXPECT_FALSE(tear_direction_from_name("Fan", d));
  EXPECT_FALSE(tear_direction_from_name("", d));
  EXPECT_EQ(d, TearDirection::MaterialForce);  // unchanged by a refused name
}

// A start within the radius of an active tip (pattern distance) is shielded, one outside is not.
TEST(TearingStep, ShieldingRadiusAroundActiveTips) {
  const std::vector<Vec2> rest = {Vec2(0, 0), Vec2(0.1, 0.05), Vec2(0.3, 0.3)};
  const std::vector<Tip> tips = {Tip{1, 0, Vec2(0, -1)}, Tip{2, 1, Vec2(1, 0)}};
  const double r = 0.01;
  EXPECT_TRUE(shielded_by_active_tip(rest, tips, Vec2(0.1, 0.05), r));               // at the tip
  EXPECT_TRUE(shielded_by_active_tip(rest, tips, Vec2(0.1, 0.05) + 0.0099 * at_angle(30), r));
  EXPECT_TRUE(shielded_by_active_tip(rest, tips, Vec2(0.3, 0.3) + 0.005 * at_angle(200), r));  // second tip
  EXPECT_FALSE(shielded_by_active_tip(rest, tips, Vec2(0.1, 0.05) + 0.0101 * at_angle(30), r));
  EXPECT_FALSE(shielded_by_active_tip(rest, tips, Vec2(0, 0), r));  // a vertex that is no tip
  EXPECT_FALSE(shielded_by_active_tip(rest, {}, Vec2(0.1, 0.05), r));
}

// A tip may turn by up to 75° from its last segment; a new tear (no previous direction) any way.
TEST(TearingStep, TurnLimit) {
  const double limit = TearingParams{}.max_tip_turn;
  EXPECT_NEAR(limit, 75 * kPi / 180, 1e-15);
  const Vec2 previous = at_angle(-90);
  EXPECT_TRUE(tip_direction_allowed(previous, at_angle(-90), limit));
  EXPECT_TRUE(tip_direction_allowed(previous, at_angle(-90 + 74), limit));
  EXPECT_TRUE(tip_direction_allowed(previous, at_angle(-90 - 74), limit));
  EXPECT_FALSE(tip_direction_allowed(previous, at_angle(-90 + 76), limit));
  EXPECT_FALSE(tip_direction_allowed(previous, at_angle(-90 - 76), limit));
  EXPECT_FALSE(tip_direction_allowed(previous, at_angle(90), limit));  // straight back into its lips
  EXPECT_TRUE(tip_direction_allowed(Vec2::Zero(), at_angle(90), limit));
  EXPECT_EQ(tip_direction(std::vector<Tip>{Tip{3, 0, at_angle(10)}, Tip{4, 2, at_angle(20)}}, 2), at_angle(20));
  EXPECT_EQ(tip_direction(std::vector<Tip>{Tip{3, 0, at_angle(10)}}, 5), Vec2::Zero());
}

// A new tear gets the next id and its start; its tip is the cut's end vertex with the segment's direction.
TEST(TearingStep, RecordStartsANewTear) {
  std::vector<Tear> tears(2);
  tears[0].id = 0;
  tears[1].id = 1;
  std::vector<Tip> tips = {Tip{7, 1, Vec2(1, 0)}};
  std::vector<TearEvent> events;
  CutResult cut;
  cut.cut = true;
  cut.tip_vertex = 42;
  cut.end = Vec2(0.13, 0.06);
  const Vec2 uv(0.1, 0.1);
  const int32_t id = record_tear_segment(candidate(5, StartKind::Junction), uv, cut, /*parent=*/1,
                                         /*separated=*/false, /*frame=*/17, tears, tips, events);
  EXPECT_EQ(id, 2);
  ASSERT_EQ(tears.size(), 3u);
  const Tear& t = tears[2];
  EXPECT_EQ(t.id, 2);
  EXPECT_EQ(t.parent, 1);
  EXPECT_EQ(t.start_kind, StartKind::Junction);
  EXPECT_EQ(t.start_frame, 17);
  EXPECT_EQ(t.start_uv, uv);
  ASSERT_EQ(t.tips.size(), 2u);
  EXPECT_EQ(t.tips[0], uv);
  EXPECT_EQ(t.tips[1], cut.end);
  EXPECT_FALSE(t.reached_boundary);
  ASSERT_EQ(tips.size(), 2u);
  EXPECT_EQ(tips[0].tear, 1);  // the other tear's tip is untouched
  EXPECT_EQ(tips[1].vertex, 42);
  EXPECT_EQ(tips[1].tear, 2);
  EXPECT_NEAR((tips[1].direction - Vec2(0.6, -0.8)).norm(), 0, 1e-15);  // (0.03, −0.04) / 0.05
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, TearEvent::TearStarted);
  EXPECT_EQ(events[0].tear, 2);
  EXPECT_EQ(events[0].frame, 17);
}

// max_advance_per_frame: the segments a tear gets within one frame add up; a new frame starts from zero.
TEST(TearingStep, RecordSumsEachFramesAdvance) {
  std::vector<Tear> tears;
  std::vector<Tip> tips;
  std::vector<TearEvent> events;
  CutResult cut;
  cut.cut = true;
  auto segment = [&](int32_t tear, const Vec2& from, const Vec2& to, int32_t frame) {
    cut.tip_vertex = 50 + static_cast<int32_t>(events.size());
    cut.end = to;
    record_tear_segment(candidate(cut.tip_vertex, StartKind::Inward, tear), from, cut, -1, false, frame, tears, tips,
                        events);
  };
  segment(-1, Vec2(0, 0), Vec2(0, 0.002), 3);       // frame 3: 2 mm
  segment(0, Vec2(0, 0.002), Vec2(0, 0.005), 3);    // + 3 mm
  segment(0, Vec2(0, 0.005), Vec2(0.004, 0.008), 4);  // frame 4: 5 mm alone
  ASSERT_EQ(tears.size(), 1u);
  EXPECT_NEAR(tears[0].max_frame_advance, 0.005, 1e-15);
  segment(0, Vec2(0.004, 0.008), Vec2(0.004, 0.0085), 4);  // frame 4: 5.5 mm
  EXPECT_NEAR(tears[0].max_frame_advance, 0.0055, 1e-15);
  segment(0, Vec2(0.004, 0.0085), Vec2(0.004, 0.0095), 9);
  EXPECT_NEAR(tears[0].max_frame_advance, 0.0055, 1e-15);
}

// An existing tear keeps its start, appends the end and moves its tip; reaching the boundary removes the
// tip, and a separated piece is reported after the extension.
TEST(TearingStep, RecordExtendsAndEndsATear) {
  std::vector<Tear> tears(1);
  tears[0].id = 0;
  tears[0].start_frame = 3;
  tears[0].start_uv = Vec2(0.1, 0.2);
  tears[0].tips = {Vec2(0.1, 0.2), Vec2(0.1, 0.17)};
  std::vector<Tip> tips = {Tip{9, 0, Vec2(0, -1)}};
  std::vector<TearEvent> events;
  CutResult cut;
  cut.cut = true;
  cut.tip_vertex = 11;
  cut.end = Vec2(0.12, 0.17);
  EXPECT_EQ(record_tear_segment(candidate(9, StartKind::Inward, 0), Vec2(0.1, 0.17), cut, -1, false, 4, tears, tips,
                                events),
            0);
  ASSERT_EQ(tips.size(), 1u);
  EXPECT_EQ(tips[0].vertex, 11);
  EXPECT_EQ(tips[0].direction, Vec2(1, 0));
  EXPECT_EQ(tears[0].start_frame, 3);
  EXPECT_EQ(tears[0].tips.back(), cut.end);

  cut.tip_vertex = -1;
  cut.reached_boundary = true;
  cut.end = Vec2(0.2, 0.17);
  record_tear_segment(candidate(11, StartKind::Inward, 0), Vec2(0.12, 0.17), cut, -1, true, 5, tears, tips, events);
  EXPECT_TRUE(tips.empty());
  EXPECT_TRUE(tears[0].reached_boundary);
  ASSERT_EQ(tears.size(), 1u);
  EXPECT_EQ(tears[0].tips.size(), 4u);
  ASSERT_EQ(events.size(), 3u);
  EXPECT_EQ(events[0].kind, TearEvent::TearExtended);
  EXPECT_EQ(events[1].kind, TearEvent::TearExtended);
  EXPECT_EQ(events[1].frame, 5);
  EXPECT_EQ(events[2].kind, TearEvent::PieceSeparated);
  EXPECT_EQ(events[2].tear, 0);
}

TEST(TearingStep, RoleFlagsFollowFingersAndTips) {
  std::vector<uint8_t> flags = {kFinger | kBoundary, kTip, 0, kFinger};
  std::vector<Finger> fingers(2);
  fingers[0].vertex = 2;
  fingers[1].vertex = -1;  // released
  refresh_role_flags(fingers, {Tip{3, 0, Vec2::Zero()}}, flags);
  EXPECT_EQ(flags[0], kBoundary);
  EXPECT_EQ(flags[1], 0);
  EXPECT_EQ(flags[2], kFinger);
  EXPECT_EQ(flags[3], kTip);
}

// Below Griffith's bound Σ‖f_k‖ / e < Ef the candidate is not clustered; above it, it is.
TEST(TearingStep, GriffithBoundSkipsClustering) {
  Sheet s = notched_sheet();
  const int32_t p = notch_vertex();
  load_opening(p, 1e-3, s);  // two triangles in p's fan: Σ‖f_k‖ = 2e-3 N, bound 20 J/m²
  const TearingParams params = step_params();
  ForceClusters clusters;
  Candidate c = candidate(p);
  c.fracture_energy = 21;
  EXPECT_FALSE(cluster_candidate(params, c, s, clusters));
  c.fracture_energy = 19;
  EXPECT_TRUE(cluster_candidate(params, c, s, clusters));
  EXPECT_GT(clusters.left_count, 0);
  EXPECT_GT(clusters.right_count, 0);
}

// One frame at the notch: the tear starts there, runs 3 cm straight down, the mesh stays valid, and the
// step relaxes once and lists the candidates once. The next frame extends the same tear from its tip.
TEST(TearingStep, NotchedSheetPropagatesAndKeepsInvariants) {
  Sheet s = notched_sheet();
  const int32_t p = notch_vertex();
  const Vec2 start = s.verts.rest[p];
  const double area = total_rest_area(s.tris);
  load_opening(p, 1.0, s);
  const TearingParams params = step_params(0.03);
  CountingHooks counting;
  std::vector<Candidate> candidates = {candidate(p)};
  counting.list = [&] { candidates.clear(); };
  Step step;
  step.run(params, counting.hooks(s), candidates, 0, s);

  EXPECT_EQ(check_mesh_invariants(s, area), "");
  EXPECT_TRUE(step.log.violations.empty()) << step.log.violations.front();
  EXPECT_EQ(step.log.remeshes, 1);
  EXPECT_EQ(counting.relaxed, 1);
  EXPECT_EQ(counting.relaxed_tears, std::vector<int32_t>{0});
  EXPECT_EQ(counting.listed, 1);
  EXPECT_EQ(counting.forces, 0);
  ASSERT_EQ(s.tears.size(), 1u);
  const Tear& t = s.tears[0];
  EXPECT_EQ(t.start_kind, StartKind::Inward);
  EXPECT_EQ(t.start_uv, start);
  ASSERT_EQ(t.tips.size(), 2u);
  EXPECT_NEAR((t.tips[1] - (start + Vec2(0, -0.03))).norm(), 0, 1e-12);
  ASSERT_EQ(s.tips.size(), 1u);
  const int32_t tip = s.tips[0].vertex;
  EXPECT_EQ(s.verts.rest[tip], t.tips[1]);
  EXPECT_NEAR((s.tips[0].direction - Vec2(0, -1)).norm(), 0, 1e-12);
  EXPECT_TRUE(s.verts.flags[tip] & kTip);
  EXPECT_NEAR(interior_pattern_angle(s.topo, s.verts.rest, tip), 2 * kPi, 1e-9);
  ASSERT_EQ(step.log.events.size(), 1u);
  EXPECT_EQ(step.log.events[0].kind, TearEvent::TearStarted);
  EXPECT_GE(step.times.clustering, 0);
  EXPECT_GE(step.times.remeshing, 0);

  load_opening(tip, 1.0, s);
  candidates = {candidate(tip, StartKind::Inward, 0)};
  step.run(params, counting.hooks(s), candidates, 1, s);
  EXPECT_EQ(check_mesh_invariants(s, area), "");
  EXPECT_TRUE(step.log.violations.empty());
  ASSERT_EQ(s.tears.size(), 1u);
  ASSERT_EQ(s.tears[0].tips.size(), 3u);
  EXPECT_NEAR((s.tears[0].tips[2] - (start + Vec2(0, -0.06))).norm(), 0, 1e-12);
  ASSERT_EQ(step.log.events.size(), 2u);
  EXPECT_EQ(step.log.events[1].kind, TearEvent::TearExtended);
  EXPECT_EQ(step.log.events[1].frame, 1);
  ASSERT_EQ(s.tips.size(), 1u);
  EXPECT_EQ(s.verts.rest[s.tips[0].vertex], s.tears[0].tips[2]);
}

// A step long enough to leave the sheet ends the tear on the boundary, splits the sheet in two and
// removes the tip.
TEST(TearingStep, TipReachingTheBoundaryIsRemoved) {
  Sheet s = notched_sheet();
  const int32_t p = notch_vertex();
  const double area = total_rest_area(s.tris);
  load_opening(p, 1.0, s);
  CountingHooks counting;
  std::vector<Candidate> candidates = {candidate(p)};
  counting.list = [&] { candidates.clear(); };
  Step step;
  step.run(step_params(1.0), counting.hooks(s), candidates, 0, s);
  EXPECT_EQ(check_mesh_invariants(s, area), "");
  ASSERT_EQ(s.tears.size(), 1u);
  EXPECT_TRUE(s.tears[0].reached_boundary);
  EXPECT_NEAR(s.tears[0].tips.back().y(), 0, 1e-12);
  EXPECT_TRUE(s.tips.empty());
  EXPECT_EQ(s.topo.piece_count, 2);
  ASSERT_EQ(step.log.events.size(), 2u);
  EXPECT_EQ(step.log.events[0].kind, TearEvent::TearStarted);
  EXPECT_EQ(step.log.events[1].kind, TearEvent::PieceSeparated);
}

// Every top-edge vertex is a finger start (not shielded) and is loaded again after each relaxation:
// the frame stops after max_propagations propagations, one relaxation and one listing each.
TEST(TearingStep, BudgetBoundsPropagationsPerFrame) {
  for (const int32_t budget : {1, 3, 64}) {
    Sheet s = notched_sheet();
    const double area = total_rest_area(s.tris);
    std::vector<Candidate> candidates;
    auto list_top_edge = [&] { list_loaded_top_edge(s, candidates); };
    list_top_edge();
    ASSERT_GE(candidates.size(), 6u);
    CountingHooks counting;
    counting.list = list_top_edge;
    TearingParams params = step_params(0.03);
    params.max_propagations = budget;
    Step step;
    step.run(params, counting.hooks(s), candidates, 0, s);
    // 64 is more than there are starts: then every top-edge vertex but the corners starts a tear.
    const int32_t expected = std::min(budget, 8);
    EXPECT_EQ(counting.relaxed, expected);
    EXPECT_EQ(counting.listed, expected);
    EXPECT_EQ(step.log.remeshes, expected);
    EXPECT_EQ(static_cast<int32_t>(s.tears.size()), expected);
    EXPECT_EQ(check_mesh_invariants(s, area), "");
    EXPECT_TRUE(step.log.violations.empty());
  }
}

// Quasi-static tearing judges starts only at the state the physics stopped at: of eight loaded top-edge
// points one starts a tear, and the others wait for the next stop, whose forces are not a relaxation
// substep's. The same candidates without quasi-static tearing all start (the budget test above).
TEST(TearingStep, QuasiStaticStepStartsOneTearPerStop) {
  Sheet s = notched_sheet();
  std::vector<Candidate> candidates;
  auto list_top_edge = [&] { list_loaded_top_edge(s, candidates); };
  list_top_edge();
  ASSERT_GE(candidates.size(), 6u);
  CountingHooks counting;
  counting.list = list_top_edge;
  TearingParams params = step_params(0.03);
  params.quasi_static = true;
  Step step;
  step.run(params, counting.hooks(s), candidates, 0, s);
  EXPECT_EQ(s.tears.size(), 1u);
  EXPECT_EQ(step.log.remeshes, 1);
  // The next stop starts the next one.
  list_top_edge();
  step.run(params, counting.hooks(s), candidates, 1, s);
  EXPECT_EQ(s.tears.size(), 2u);
}

// Of the starts due at one stop the strongest starts (the largest Er/Ef reached Griffith's threshold first
// as the load grew), wherever it stands in the candidates' order: two loaded top-edge points, the one
// listed first pulled with a third of the other's force.
TEST(TearingStep, QuasiStaticStepStartsTheStrongestStart) {
  for (const bool stronger_first : {false, true}) {
    Sheet s = notched_sheet();
    const std::vector<int32_t> top = top_edge_vertices(s);
    ASSERT_GE(top.size(), 6u);
    const int32_t weak = top[1], strong = top[top.size() - 2];
    const std::vector<Candidate> candidates = {candidate(stronger_first ? strong : weak, StartKind::Finger),
                                               candidate(stronger_first ? weak : strong, StartKind::Finger)};
    load_opening(weak, 1.0, s);
    load_opening(strong, 3.0, s);
    const Vec2 strong_uv = s.verts.rest[strong];
    CountingHooks counting;  // relax clears the load: nothing more propagates in this step
    TearingParams params = step_params(0.03);
    params.quasi_static = true;
    Step step;
    step.run(params, counting.hooks(s), candidates, 0, s);
    ASSERT_EQ(s.tears.size(), 1u) << "stronger first: " << stronger_first;
    EXPECT_EQ(s.tears[0].start_uv, strong_uv) << "stronger first: " << stronger_first;
  }
}

// With the next frame's physics as the relaxation the step ends after its first propagation: the forces
// and candidates are brought to the new mesh, and relax is not called.
TEST(TearingStep, NextFrameRelaxationStopsAfterOnePropagation) {
  Sheet s = notched_sheet();
  std::vector<Candidate> candidates;
  auto list_top_edge = [&] { list_loaded_top_edge(s, candidates); };
  list_top_edge();
  CountingHooks counting;
  counting.list = list_top_edge;
  TearingParams params = step_params(0.03);
  params.relaxation = TearRelaxation::NextFrame;
  Step step;
  step.run(params, counting.hooks(s), candidates, 0, s);
  EXPECT_EQ(counting.relaxed, 0);
  EXPECT_EQ(counting.forces, 1);
  EXPECT_EQ(counting.listed, 1);
  EXPECT_EQ(s.tears.size(), 1u);
}

// A new start right behind an active tip is skipped by the step, the same start away from it is not.
TEST(TearingStep, StepSkipsShieldedStarts) {
  Sheet s = notched_sheet();
  const int32_t p = notch_vertex();
  const int32_t neighbour = p + 1;  // the top-edge vertex 2 cm to the right
  load_opening(neighbour, 1.0, s);
  s.tears.resize(1);  // tear 0, whose active tip is at the notch, 2.2 cm away
  s.tears[0].id = 0;
  s.tips.push_back(Tip{p, 0, Vec2(0, -1)});
  std::vector<Candidate> candidates = {candidate(neighbour)};
  CountingHooks counting;
  counting.list = [&] { candidates.clear(); };
  TearingParams params = step_params(0.03);
  params.shielding_radius = 0.025;
  Step step;
  Sheet shielded = s;
  step.run(params, counting.hooks(shielded), candidates, 0, shielded);
  EXPECT_EQ(step.log.remeshes, 0);
  EXPECT_EQ(counting.relaxed, 0);
  params.shielding_radius = 0.02;
  step.run(params, counting.hooks(s), candidates, 0, s);
  EXPECT_EQ(step.log.remeshes, 1);
  EXPECT_EQ(counting.relaxed, 1);
}

// The engine's substep stop asks whether the step would cut: a trouser tip held at its legs with the
// tension rays, below and above Griffith's threshold, agrees with what the step then does; a tip the turn
// limit holds does not count.
TEST(TearingStep, WouldTearAgreesWithTheStep) {
  const double ef = 2e4, threshold = ef * 1e-4 / 2;  // per finger: Er = (F_L + F_R)/e
  for (const double scale : {0.99, 1.01}) {
    Sheet s = test::slit_grid(0.2, 0.15, 10, 6, {{5, 3}});
    const int32_t tip = test::vertex_at(s, Vec2(0.1, 0.075));
    for (const double side : {-1.0, 1.0}) {
      Finger f;
      f.vertex = test::vertex_at(s, Vec2(0.1, 0), Vec2(side, 0.1));
      f.reaction = Vec3(0, 0, side * scale * threshold);  // the legs pulled apart
      s.fingers.push_back(f);
    }
    s.tears.resize(1);
    s.tears[0].id = 0;
    s.tears[0].tips = {Vec2(0.1, 0), Vec2(0.1, 0.075)};
    s.tips.push_back(Tip{tip, 0, Vec2(0, 1)});
    TearingParams params = step_params(0.01);
    params.direction = TearDirection::TensionRays;
    params.quasi_static = true;
    std::vector<Candidate> candidates = {Candidate{tip, StartKind::Inward, 0, ef}};
    Step step;
    const bool would = tension_rays_would_tear(params, candidates, s, step.scratch);
    EXPECT_EQ(would, scale > 1) << "scale " << scale;
    CountingHooks counting;
    counting.list = [&] { candidates.clear(); };
    step.run(params, counting.hooks(s), candidates, 0, s);
    EXPECT_EQ(step.log.remeshes, would ? 1 : 0);

    // The turn limit: the same pull on a tip whose last segment ran at 45°.
    if (scale > 1) {
      Sheet sideways = s;
      sideways.tips[0].direction = Vec2(1, 1).normalized();
      TearingParams strict = params;
      strict.max_tip_turn = 30.0 * kPi / 180;
      const std::vector<Candidate> tip_only = {Candidate{sideways.tips[0].vertex, StartKind::Inward, 0, ef}};
      EXPECT_TRUE(tension_rays_would_tear(params, tip_only, sideways, step.scratch));  // 45° < 75°
      EXPECT_FALSE(tension_rays_would_tear(strict, tip_only, sideways, step.scratch));
    }
  }
}
