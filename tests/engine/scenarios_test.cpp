// The paper's result figures as scenario files (scenarios/), checked for what the paper claims: where
// tears start, where they run (the mediator, the hyperbola), how many there are, and what the fingers hold.
// Every scenario runs with the mesh invariants (check_mesh_invariants, systems/common/topology.hpp) checked after
// every remesh. The history of these measurements with the fan rule and the material force is in
// bench/results/2026-12-01-path-claims-history.txt; the zigzag and branching claims are not met yet
// (docs/tearing.md, "Known gaps") and their tests stay disabled. The same claims over 16 meshes are measured
// by tools/path_claims.cpp (build/bin/papertear-path-claims), which shares tools/path_measures.hpp.
#include "engine/scenario.hpp"
#include "engine/simulation.hpp"
#include "engine/simulation_internals.hpp"
#include "systems/common/topology.hpp"
#include "tools/path_measures.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <numbers>

using namespace pt;
using pt::path_claims::direction_changes;
using pt::path_claims::mediator_error;

namespace {

std::string scenario_path(const std::string& name) { return std::string(PT_SOURCE_DIR) + "/scenarios/" + name; }

struct ScenarioRun {
  std::unique_ptr<Simulation> sim;
  const Sheet& sheet() const { return sim->sheet(); }
};

ScenarioRun run_scenario(const Scenario& s, int32_t threads = 1) {
  EngineOptions o;
  o.threads = threads;
  o.check_invariants = true;
  ScenarioRun r{std::make_unique<Simulation>(s, o)};
  for (int32_t f = 0; f < s.sim.frames; ++f) r.sim->step();
  r.sim->flush();
  return r;
}

double path_length(const std::vector<Vec2>& p) {
  double l = 0;
  for (size_t i = 1; i < p.size(); ++i) l += (p[i] - p[i - 1]).norm();
  return l;
}

// scenarios/<file> meshed with sheet.mesh_seed = seed and its meshing frame turned 17° per seed, as
// tools/paper_check.py --seeds and papertear-path-claims mesh it.
Scenario scenario_on_mesh(const char* file, uint64_t seed) {
  Scenario s = load_scenario(scenario_path(file));
  s.mesh_seed = seed;
  s.mesh_rotation_deg = 17.0 * static_cast<double>(seed);
  return s;
}

// Strictly between the leftmost and the rightmost finger in u: between the hands.
bool between_the_hands(const Scenario& s, const Vec2& uv) {
  double lo = 1e9, hi = -1e9;
  for (const FingerSpec& f : s.fingers) lo = std::min(lo, f.at.x()), hi = std::max(hi, f.at.x());
  return uv.x() > lo && uv.x() < hi;
}

Vec2 finger_uv(const Scenario& s, const std::string& name) {
  for (const FingerSpec& f : s.fingers)
    if (f.name == name) return f.at;
  ADD_FAILURE() << "no finger " << name;
  return Vec2::Zero();
}

void expect_no_violations(const Simulation& sim) {
  for (const std::string& v : sim.invariant_violations()) ADD_FAILURE() << v;
}

bool all_finite(const Sheet& s) {
  for (const Vec3& x : s.verts.x)
    if (!x.allFinite()) return false;
  for (const Vec3& v : s.verts.v)
    if (!v.allFinite()) return false;
  for (const Tear& t : s.tears)
    for (const Vec2& p : t.tips)
      if (!p.allFinite()) return false;
  return true;
}

// The state hash of the scenario run on two threads with kernel ranges of 8 triangles: every sheet of the
// figures then goes through the flow graph, with its kernels split.
std::string hash_with_split_ranges(const Scenario& s) {
  EngineOptions o;
  o.threads = 2;
  o.parallel_grain = 8;
  Simulation sim(s, o);
  for (int32_t f = 0; f < s.sim.frames; ++f) sim.step();
  sim.flush();
  return sim.state_hash();
}

}  // namespace

// Every scenario of scenarios/ runs to its end: valid mesh after every remesh, no NaN, tears recorded.
class EveryScenario : public ::testing::TestWithParam<std::string> {};

TEST_P(EveryScenario, RunsWithMeshInvariantsAndNoNaN) {
  const Scenario s = load_scenario(scenario_path(GetParam()));
  ScenarioRun r = run_scenario(s);
  expect_no_violations(*r.sim);
  EXPECT_TRUE(all_finite(r.sheet()));
  // fig18-crumple's fingers reach their grip and slip before any start passes on its own mesh since the
  // compression relief (docs/tearing.md, "Known gaps"); every other figure scenario tears.
  if (GetParam() != std::string("fig18-crumple.json")) {
    EXPECT_FALSE(r.sheet().tears.empty()) << "every figure scenario tears";
  }
  EXPECT_EQ(check_mesh_invariants(r.sheet()), "");
  EXPECT_LE(r.sim->max_strain_beyond_tips(), r.sim->max_strain()) << "a part of the sheet cannot stretch more";
  // A refused substep leaves the whole sheet where it was (no NaN enters it), so it must stay an exception.
  EXPECT_EQ(solver_stats(*r.sim).failures, 0) << "substeps the implicit solver refused";
}

// Regression: on these meshes the tears used to leave slivers (a vertex 2·10⁻⁸ m from
// another, where a cut ended on an edge next to its end) and the column factorisation, then LDLᵀ through
// explicit 3x3 pivot inverses, lost positive definiteness to rounding on pivots of condition ~10⁷: 82–1 103
// of the 900–1 500 substeps were refused and the sheet stood still for them. Now none is.
TEST(Scenarios, NoSubstepIsRefusedOnMeshesThatUsedToFreeze) {
  struct Case {
    const char* file;
    uint64_t mesh;
  };
  for (const Case c : {Case{"fig16-zigzag.json", 3}, Case{"fig16-zigzag.json", 5}, Case{"fig14-straight.json", 4},
                       Case{"fig15-curved.json", 1}}) {
    const Scenario s = scenario_on_mesh(c.file, c.mesh);
    ScenarioRun r = run_scenario(s);
    EXPECT_EQ(solver_stats(*r.sim).failures, 0) << c.file << " mesh " << c.mesh;
    expect_no_violations(*r.sim);
  }
}

INSTANTIATE_TEST_SUITE_P(Scenarios, EveryScenario,
                         ::testing::Values("demo.json", "fig12-junction.json", "fig13-twist.json",
                                           "fig14-straight.json", "fig14-inplane.json", "fig15-curved.json",
                                           "fig16-direction.json",
                                           "fig16-zigzag.json", "fig17-branching.json", "fig18-crumple.json",
                                           "fig19-sigma1mm.json", "fig21-notch.json", "start-finger.json",
                                           "start-inward.json", "start-junction.json", "torn-in-two.json",
                                           "a4-10k-patch.json"),
                         [](const auto& info) {
                           std::string n = info.param.substr(0, info.param.size() - 5);
                           for (char& c : n)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return n;
                         });

// Paper that is only pushed together, bent or waved buckles for almost nothing and does not tear: at
// the end of each scene the fingers hold at most 0.3 N, none slips, and the in-plane strain stays under 2%.
TEST(Scenarios, PushedBentOrWavedSheetsDoNotTearAndHoldLittle) {
  for (const char* file : {"push-together.json", "bent-cylinder.json", "waved-corners.json"}) {
    const Scenario s = load_scenario(scenario_path(file));
    ScenarioRun r = run_scenario(s);
    EXPECT_TRUE(r.sheet().tears.empty()) << file;
    for (const Finger& f : r.sheet().fingers) {
      EXPECT_LE(f.reaction.norm(), 0.3) << file << " finger " << f.name;
      EXPECT_EQ(f.slips, 0) << file << " finger " << f.name;
    }
    EXPECT_LE(r.sim->max_strain(), 0.02) << file;
    expect_no_violations(*r.sim);
  }
}

// Compression relief (material.compression_scale, default 0.05; docs/physics.md "Compression relief"):
// with a compressed direction keeping a twentieth of its stiffness, the coarse meshes that lock no longer
// do. Four fingers pushing an A5 sheet together on ~160 triangles reach their 15 N grip with the relief
// off (below). With it, on ~120, 500 and 2 000 triangles no sheet tears or slips, and (measured) the push
// peaks at 0.22 / 0.18 / 0.16 N, the bent arch at 0.34 / 0.27 / 0.25 N and the waved sheet at 0.11 / 0.11
// / 0.10 N. Bounds: every peak within 0.3 N but the arch's on ~120 triangles (0.4 N), and within 50% of
// each other (the waved sheet's 25%).
TEST(Scenarios, CompressionReliefLetsCoarseSheetsBuckleWithoutLocking) {
  auto peak_of = [](const char* file, int32_t triangles, double compression_scale, size_t& tears, int& slips) {
    Scenario s = load_scenario(scenario_path(file));
    s.triangles = triangles;
    if (compression_scale > 0) s.material.compression_scale = compression_scale;
    ScenarioRun r = run_scenario(s);
    double peak = 0;
    slips = 0;
    for (const Finger& f : r.sheet().fingers) {
      peak = std::max(peak, f.max_force);
      slips += f.slips;
    }
    tears = r.sheet().tears.size();
    expect_no_violations(*r.sim);
    return peak;
  };
  size_t tears = 0;
  int slips = 0;
  EXPECT_GE(peak_of("push-together.json", 160, 1.0, tears, slips), 5.0)
      << "without the relief the coarse sheet locks: newtons where paper buckles for millinewtons";
  struct Case {
    const char* file;
    double coarse_bound, spread;
  };
  for (const Case c : {Case{"push-together.json", 0.3, 1.5}, Case{"bent-cylinder.json", 0.4, 1.5},
                       Case{"waved-corners.json", 0.3, 1.25}}) {
    double lo = 1e9, hi = 0;
    for (const int32_t triangles : {120, 500, 2000}) {
      const double peak = peak_of(c.file, triangles, -1, tears, slips);
      EXPECT_EQ(tears, 0u) << c.file << " " << triangles;
      EXPECT_EQ(slips, 0) << c.file << " " << triangles;
      EXPECT_LE(peak, triangles < 200 ? c.coarse_bound : 0.3) << c.file << " " << triangles;
      lo = std::min(lo, peak), hi = std::max(hi, peak);
    }
    EXPECT_LE(hi, c.spread * lo) << c.file;
  }
}

// sheet.hand_lines (docs/physics.md, "Fingers"): the line between a hand's two fingers is where the sheet
// pivots; on a coarse mesh that does not follow it the triangles straddling it lock. With the membrane's
// whole compressive stiffness (compression_scale 1, the relief off), four fingers pushing an A5 sheet
// together on ~250 triangles hold their 15 N grip and slip without the lines (mesh seed 0); with them, on
// four meshes, the sheet never tears, no finger slips and they peak at 0.53–0.59 N, as on 500 and 2 000
// triangles without them (0.54–0.57 N).
TEST(Scenarios, HandLinesKeepACoarsePushedSheetFromLocking) {
  auto run_push = [](uint64_t seed, bool hand_lines, double& peak, int& slips) {
    Scenario s = scenario_on_mesh("push-together.json", seed);
    s.triangles = 250;
    s.hand_lines = hand_lines;
    s.material.compression_scale = 1;
    ScenarioRun r = run_scenario(s);
    peak = 0;
    slips = 0;
    for (const Finger& f : r.sheet().fingers) {
      peak = std::max(peak, f.max_force);
      slips += f.slips;
    }
    expect_no_violations(*r.sim);
    return r.sheet().tears.size();
  };
  double peak = 0;
  int slips = 0;
  run_push(0, false, peak, slips);
  EXPECT_GE(peak, 5.0) << "without the lines this mesh locks";
  for (const uint64_t seed : {0, 1, 2, 3}) {
    EXPECT_EQ(run_push(seed, true, peak, slips), 0u) << "seed " << seed;
    EXPECT_EQ(slips, 0) << "seed " << seed;
    EXPECT_LE(peak, 0.7) << "seed " << seed;
  }
}

// Sheets torn from their border by fingers near it tear without a finger slipping, and no finger holds
// more than 5 N, on their own meshes (seed 0) and 3 more (mesh seeds 1-3, the meshing frame turned 17
// degrees per seed, as tools/paper_check.py --seeds 4). The zigzag's hand lifting one side of the notch
// tears it as a trouser's leg (3.1 N on its own mesh; 5.2 N when every pull was read in the plane,
// docs/tearing.md "Direction and Er"). A start cut within one substep stops where Griffith's test first
// holds on the substep's straight path (the stop's bisection); when the bisection mixed its ends,
// start-finger, table-tear and the zigzag read 5.05-5.65 N on one mesh each, and before the opening floor
// a tip level with demo's inner fingers stalled until they held 7.2 N (docs/tearing.md, "Direction and Er
// at a tip" and "Quasi-static tearing"). fig18-crumple and u-twist-pull, whose fingers hold inside the
// sheet, slip at their grip (docs/tearing.md, "Known gaps").
// One test per scene (14 scenes x 4 meshes in one test took 21 s, and over 600 s under ASan+UBSan).
class BorderTearsStayBelow5NOnFourMeshes : public ::testing::TestWithParam<std::string> {};

TEST_P(BorderTearsStayBelow5NOnFourMeshes, WithoutASlip) {
  const std::string file = GetParam();
  for (const uint64_t seed : {0, 1, 2, 3}) {
    Scenario s = load_scenario(scenario_path(file));
    s.mesh_seed = seed;
    s.mesh_rotation_deg = 17.0 * double(seed);
    ScenarioRun r = run_scenario(s, 2);
    EXPECT_FALSE(r.sheet().tears.empty()) << file << " seed " << seed;
    for (const Finger& f : r.sheet().fingers) {
      EXPECT_EQ(f.slips, 0) << file << " seed " << seed << " finger " << f.name;
      EXPECT_LE(f.max_force, 5.0) << file << " seed " << seed << " finger " << f.name;
    }
    expect_no_violations(*r.sim);
  }
}

INSTANTIATE_TEST_SUITE_P(Scenarios, BorderTearsStayBelow5NOnFourMeshes,
                         ::testing::Values("demo.json", "fig12-junction.json", "fig13-twist.json",
                                           "fig14-inplane.json", "fig14-straight.json", "fig15-curved.json",
                                           "fig16-direction.json", "fig16-zigzag.json", "fig17-branching.json",
                                           "fig21-notch.json", "start-finger.json", "start-inward.json",
                                           "table-tear.json", "torn-in-two.json"),
                         [](const auto& info) {
                           std::string n = info.param.substr(0, info.param.size() - 5);
                           for (char& c : n)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return n;
                         });

// An edge start reads Er = N_tt · start_length / e (docs/tearing.md "Starts"): the longer the edge whose
// tension is taken to open the tear, the less the pinching finger of start-finger must pull (measured
// 5.7-6.0 / 3.1 / 1.8 N at 5 mm / 1 cm / 2 cm), and the key tearing.start_length reaches the step.
TEST(Scenarios, EdgeStartForceFallsWithTheStartLength) {
  const Scenario base = load_scenario(scenario_path("start-finger.json"));
  auto start_force = [&](double start_length) {
    Scenario s = base;
    s.tearing.start_length = start_length;
    EngineOptions o;
    o.threads = 1;
    Simulation sim(s, o);
    while (sim.frame() < s.sim.frames && sim.sheet().tears.empty()) sim.step();
    EXPECT_EQ(sim.sheet().tears.size(), 1u) << start_length;
    double most = 0;
    for (const Finger& f : sim.sheet().fingers) most = std::max(most, f.max_force);
    return most;
  };
  const double shortest = start_force(0.005), usual = start_force(0.01), longest = start_force(0.02);
  EXPECT_GT(shortest, usual);
  EXPECT_GT(usual, longest);
  EXPECT_GT(shortest / longest, 2.0) << "Er grows with the length: a quarter of it needs much more pull";
}

// The force at which a tear starts is the sheet's, not the time step's: the frame's physics stops at the
// state where the start is due, inside a substep if need be (docs/tearing.md "Quasi-static tearing"), so
// the fingers' peak up to the first start moves by at most 10% from 10 to 40 substeps a frame. A finger
// start at the strain limit (start-finger) and a notch start (fig21-notch).
TEST(Scenarios, StartForceDoesNotDependOnTheSubsteps) {
  for (const char* file : {"start-finger.json", "fig21-notch.json"}) {
    double peak[2] = {0, 0};
    for (int k = 0; k < 2; ++k) {
      Scenario s = load_scenario(scenario_path(file));
      s.sim.substeps = k == 0 ? 10 : 40;
      EngineOptions o;
      o.threads = 1;
      Simulation sim(s, o);
      for (int32_t f = 0; f < s.sim.frames && sim.sheet().tears.empty(); ++f) sim.step();
      ASSERT_FALSE(sim.sheet().tears.empty()) << file << " at " << s.sim.substeps << " substeps";
      for (const Finger& f : sim.sheet().fingers) {
        EXPECT_EQ(f.slips, 0) << file << " finger " << f.name;
        peak[k] = std::max(peak[k], f.max_force);
      }
    }
    EXPECT_NEAR(peak[1], peak[0], 0.1 * peak[0]) << file;
  }
}

// The trouser test (scenarios/trouser-pull.json: a 4 x 12 cm strip slit 6 cm, its legs pulled one up
// and one down): Griffith's criterion with Er = ‖P_L − P_R‖ cos(θ/2) / e starts the tear when each finger
// holds Ef·e/2 (fibre floor 1, so Ef = c everywhere: 1.25 N; θ = 21° between the legs' fingers seen from
// the slit's end adds 1.6%), and the tip, D·Ef, advances when they hold D·Ef·e/2 (0.19 N). Both on three
// meshes (seed and rotation) at three densities: what starts and drives the tear is the fingers' pull,
// not the triangles at the tip.
TEST(Scenarios, TrouserPullStartsAtHalfEfTimesThicknessOnEveryMesh) {
  const Scenario base = load_scenario(scenario_path("trouser-pull.json"));
  ASSERT_EQ(base.material.fiber_floor, 1.0);
  const double start = base.material.fracture_c * base.material.thickness / 2;
  const double advance = base.material.tip_damage * start;
  for (const int32_t triangles : {150, 300, 600})
    for (const uint64_t mesh : {0, 1, 2}) {
      Scenario s = base;
      s.triangles = triangles;
      s.mesh_seed = mesh;
      s.mesh_rotation_deg = 17.0 * static_cast<double>(mesh);
      EngineOptions o;
      o.threads = 1;
      Simulation sim(s, o);
      const std::string what = std::to_string(triangles) + " triangles, mesh " + std::to_string(mesh);
      auto held = [&] {
        double most = 0;
        for (const Finger& f : sim.sheet().fingers) most = std::max(most, f.max_force);
        return most;
      };
      while (sim.frame() < s.sim.frames && sim.sheet().tears.empty()) sim.step();
      ASSERT_EQ(sim.sheet().tears.size(), 1u) << what;
      EXPECT_NEAR(held(), start, 0.05 * start) << what;
      // While the tear runs down the strip, until the legs come apart.
      double running = 0;
      int32_t frames_running = 0;
      while (sim.frame() < s.sim.frames && sim.sheet().topo.piece_count == 1) {
        sim.step();
        for (const Finger& f : sim.sheet().fingers) running = std::max(running, f.reaction.norm());
        ++frames_running;
      }
      EXPECT_EQ(sim.sheet().topo.piece_count, 2) << what;
      EXPECT_GT(frames_running, 10) << what << ": the tear ran away";
      EXPECT_GT(running, 0.5 * advance) << what;
      EXPECT_LT(running, 1.1 * advance) << what;
      EXPECT_EQ(sim.sheet().tears.size(), 1u) << what;
      for (const Finger& f : sim.sheet().fingers) EXPECT_EQ(f.slips, 0) << what;
    }
}

// A pull that asks more of the pinch than its grip: with a vice-like grip the fingers of the twisted U
// hold far more than a hand's 15 N; with the default grip the paper slides through them instead (slips
// counted), and the sheet stays valid.
TEST(Scenarios, FingersSlipRatherThanHoldMoreThanTheirGrip) {
  Scenario vice = load_scenario(scenario_path("u-twist-pull.json"));
  for (FingerSpec& f : vice.fingers) f.grip = 1e4;
  ScenarioRun held = run_scenario(vice);
  double most = 0;
  for (const Finger& f : held.sheet().fingers) most = std::max(most, f.max_force);
  EXPECT_GT(most, 15.0) << "the scene asks more than a pinch holds";

  ScenarioRun r = run_scenario(load_scenario(scenario_path("u-twist-pull.json")));
  int32_t slips = 0;
  for (const Finger& f : r.sheet().fingers) {
    slips += f.slips;
    EXPECT_LE(f.max_force, f.grip) << f.name;
  }
  EXPECT_GT(slips, 0);
  EXPECT_TRUE(all_finite(r.sheet()));
  expect_no_violations(*r.sim);
}

// Fig. 14: the tear starts at the notch apex and runs down into the sheet between the fingers.
TEST(Scenarios, SymmetricPullTearsFromTheApexIntoTheSheet) {
  const Scenario s = load_scenario(scenario_path("fig14-straight.json"));
  ScenarioRun r = run_scenario(s);
  ASSERT_FALSE(r.sheet().tears.empty());
  const Tear& tear = r.sheet().tears[0];
  EXPECT_EQ(tear.start_uv, Vec2(0.074, 0.19));
  ASSERT_GE(tear.tips.size(), 3u);
  EXPECT_LT(tear.tips.back().y(), 0.19 - 0.03) << "the tear runs at least 3 cm into the sheet";
  const Vec2 a = finger_uv(s, "A"), b = finger_uv(s, "B");
  for (const Vec2& p : tear.tips) EXPECT_TRUE(p.x() > a.x() && p.x() < b.x()) << p.transpose();
}

// "relaxation": "next_frame": a propagation waits for the next frame's physics instead of an extra substep,
// so at most one coarse segment is cut per frame and no relaxation substep runs; the tear still starts at
// the notch and runs into the sheet, with the mesh invariants kept. (Its path is not the default's: on this
// mesh it runs 24 tips deep and leaves the band between the fingers, where the default's stays in it.)
TEST(Scenarios, NextFrameRelaxationCutsAtMostOncePerFrame) {
  Scenario s = load_scenario(scenario_path("fig14-straight.json"));
  s.sim.relaxation = "next_frame";
  EngineOptions o;
  o.threads = 1;
  o.check_invariants = true;
  Simulation sim(s, o);
  int64_t cuts = 0;
  for (int32_t f = 0; f < s.sim.frames; ++f) {
    sim.step();
    EXPECT_LE(sim.remesh_count() - cuts, 1) << "frame " << f;
    cuts = sim.remesh_count();
    EXPECT_EQ(sim.last_profile().relaxation, 0.0) << "frame " << f;
  }
  sim.flush();
  ASSERT_FALSE(sim.sheet().tears.empty());
  const Tear& tear = sim.sheet().tears[0];
  EXPECT_EQ(tear.start_uv, Vec2(0.074, 0.19));
  EXPECT_LT(tear.tips.back().y(), 0.19 - 0.03) << "the tear runs at least 3 cm into the sheet";
  expect_no_violations(sim);
}

// "relaxation": "patch": the relaxation after each cut solves only the vertices within 3 cm of the tear
// (systems/physics/local_relaxation.hpp). Fig. 14 keeps what the default gives: its first tear starts at the notch
// and runs at least 3 cm into the sheet between the fingers (on this mesh: 2 tears, the first of 16 tips;
// the default: 3 tears, the first of 15 tips), with the mesh invariants kept.
TEST(Scenarios, PatchRelaxationTearsFig14BetweenTheFingers) {
  Scenario s = load_scenario(scenario_path("fig14-straight.json"));
  s.sim.relaxation = "patch";
  ScenarioRun r = run_scenario(s);
  ASSERT_FALSE(r.sheet().tears.empty());
  const Tear& tear = r.sheet().tears[0];
  EXPECT_EQ(tear.start_uv, Vec2(0.074, 0.19));
  EXPECT_LT(tear.tips.back().y(), 0.19 - 0.03) << "the tear runs at least 3 cm into the sheet";
  const Vec2 a = finger_uv(s, "A"), b = finger_uv(s, "B");
  for (const Vec2& p : tear.tips) EXPECT_TRUE(p.x() > a.x() && p.x() < b.x()) << p.transpose();
  expect_no_violations(*r.sim);
  // Bit-identical on two threads with ranges of 8 triangles, so the patch's own step runs split too.
  EXPECT_EQ(hash_with_split_ranges(s), r.sim->state_hash());
}

// The crack driving force (tearing.direction = material_force) exists because the fan's bisector does not
// see past the tip's own triangles. Fig. 14's sheet pulled apart in plane, on the four meshes of the claim
// below: its tears stay at least twice as close to the mediator as the bisector's (measured over 16 meshes,
// mean 6.0% against 35%).
// Fig. 14 pulled apart in its plane over four meshes: the tension rays (default) follow the mediator of the
// fingers far closer than the paper's literal rule on the fan ("fan") and than the J-vector
// ("material_force"), whose directions come from the few triangles around the tip. The rays' tears run
// more than 3 cm; the fan rule's, since the compression relief, stops at 1.7 cm on mesh 0 (the others run
// on), so the rules read from the fan need only 1.5 cm of path to be compared.
TEST(Scenarios, TensionRaysFollowTheMediatorInPlaneCloserThanTheFanRules) {
  const Scenario base = load_scenario(scenario_path("fig14-inplane.json"));
  double error[3] = {0, 0, 0};
  const char* directions[3] = {"tension_rays", "fan", "material_force"};
  const std::pair<uint64_t, double> meshes[] = {{0, 0.0}, {1, 17.0}, {2, 45.0}, {3, 71.0}};
  for (const auto& [seed, rotation] : meshes) {
    for (int k = 0; k < 3; ++k) {
      Scenario s = base;
      s.mesh_seed = seed;
      s.mesh_rotation_deg = rotation;
      s.tearing.direction = directions[k];
      s.tearing.snap.reset();
      ScenarioRun r = run_scenario(s);
      ASSERT_FALSE(r.sheet().tears.empty()) << directions[k] << " seed " << seed;
      EXPECT_GT(path_length(r.sheet().tears[0].tips), k == 0 ? 0.03 : 0.015) << directions[k] << " seed " << seed;
      const double e = mediator_error(s, r.sheet());
      std::printf("seed %d, %s: %.1f%% of the path length\n", static_cast<int>(seed), directions[k], 100 * e);
      error[k] += e / 4;
      expect_no_violations(*r.sim);
    }
  }
  EXPECT_LT(error[0], 0.5 * error[1]) << "mean mediator errors: tension rays " << error[0] << ", fan " << error[1];
  EXPECT_LT(error[0], 0.5 * error[2]) << "tension rays " << error[0] << ", material force " << error[2];
  EXPECT_LT(error[0], 0.06) << "within 6% of the path length on average";
}

// Fig. 14, quantitatively: within 1% of the path length from the mediator, on four meshes at two densities.
TEST(Scenarios, SymmetricPullFollowsTheMediatorOnFourMeshes) {
  const Scenario base = load_scenario(scenario_path("fig14-straight.json"));
  const Vec2 a = finger_uv(base, "A"), b = finger_uv(base, "B");
  const Vec2 axis = (b - a).normalized();
  const Vec2 mid = 0.5 * (a + b);
  const std::pair<uint64_t, double> meshes[] = {{0, 0.0}, {1, 17.0}, {2, 45.0}, {3, 71.0}};
  for (const int32_t triangles : {base.triangles, 800}) {
    for (const auto& [seed, rotation] : meshes) {
      Scenario s = base;
      s.mesh_seed = seed;
      s.mesh_rotation_deg = rotation;
      s.triangles = triangles;
      ScenarioRun r = run_scenario(s);
      ASSERT_FALSE(r.sheet().tears.empty()) << "seed " << seed;
      const Tear& tear = r.sheet().tears[0];
      const double length = path_length(tear.tips);
      EXPECT_GT(length, 0.02) << "seed " << seed;
      double worst = 0;
      for (const Vec2& p : tear.tips) worst = std::max(worst, std::abs((p - mid).dot(axis)));
      EXPECT_LE(worst, 0.01 * length) << "seed " << seed << " rotation " << rotation << ", " << triangles
                                      << " triangles: path leaves the mediator by " << worst << " m over " << length
                                      << " m";
      expect_no_violations(*r.sim);
    }
  }
}

// Fig. 15: |PA| − |PB| stays at its starting value (the hyperbola) within 2% of |AB|, at the default step
// cap and at caps that shorten the steps. Below the cap the error is set by the cut's snap (0.03 of an
// edge moves a tip by ~0.4 mm, 0.7% of |AB|), not by the step: it does not shrink further with the cap.
TEST(Scenarios, AsymmetricPullFollowsTheHyperbola) {
  const Scenario base = load_scenario(scenario_path("fig15-curved.json"));
  const Vec2 a = finger_uv(base, "A"), b = finger_uv(base, "B");
  for (const double max_step : {base.material.max_step, 0.004, 0.002}) {
    Scenario s = base;
    s.material.max_step = max_step;
    s.material.min_step = std::min(s.material.min_step, max_step);
    ScenarioRun r = run_scenario(s);
    ASSERT_FALSE(r.sheet().tears.empty()) << "cap " << max_step;
    const Tear& tear = r.sheet().tears[0];
    EXPECT_GT(path_length(tear.tips), 0.02) << "cap " << max_step;
    const double d0 = (tear.tips[0] - a).norm() - (tear.tips[0] - b).norm();
    double worst = 0;
    for (const Vec2& p : tear.tips) worst = std::max(worst, std::abs((p - a).norm() - (p - b).norm() - d0));
    std::printf("hyperbola error at a step cap of %.0f mm: %.2f%% of |AB|\n", 1e3 * max_step, 100 * worst / (a - b).norm());
    EXPECT_LE(worst, 0.02 * (a - b).norm()) << "cap " << max_step;
    expect_no_violations(*r.sim);
  }
}

TEST(Scenarios, SameResultAtOneAndTwoThreads) {
  for (const char* file : {"fig14-straight.json", "fig14-inplane.json"}) {
    const Scenario s = load_scenario(scenario_path(file));
    ScenarioRun one = run_scenario(s, 1);
    ScenarioRun two = run_scenario(s, 2);
    EXPECT_EQ(one.sim->state_hash(), two.sim->state_hash()) << file;
    ASSERT_EQ(one.sheet().tears.size(), two.sheet().tears.size()) << file;
  }
}

// A sheet within one kernel range runs its frame's systems in order on one thread, a larger one through
// the flow graph (Simulation: run_frame_in_order). Ranges of 8 triangles put these sheets on the graph,
// with their kernels split over two threads: the same results, bit for bit.
TEST(Scenarios, FrameInOrderEqualsTheGraph) {
  for (const char* file : {"demo.json", "fig17-branching.json", "torn-in-two.json"}) {
    const Scenario s = load_scenario(scenario_path(file));
    ScenarioRun in_order = run_scenario(s, 2);
    EXPECT_EQ(in_order.sim->state_hash(), hash_with_split_ranges(s)) << file;
  }
}

// §7.1 and Figs. 12, 13: where tears start.
TEST(Scenarios, StartKinds) {
  struct Case {
    const char* file;
    StartKind kind;
  };
  for (const Case& c : {Case{"fig13-twist.json", StartKind::Junction},
                        Case{"start-inward.json", StartKind::Inward}, Case{"start-finger.json", StartKind::Finger}}) {
    const Scenario s = load_scenario(scenario_path(c.file));
    ScenarioRun r = run_scenario(s);
    ASSERT_FALSE(r.sheet().tears.empty()) << c.file;
    const Tear& first = r.sheet().tears[0];
    EXPECT_EQ(first.start_kind, c.kind) << c.file;
    if (c.kind == StartKind::Junction) {
      EXPECT_TRUE(between_the_hands(s, first.start_uv)) << c.file << " at u = " << first.start_uv.x();
    }
  }
}

// Fig. 12: the hands flatten the border they hold near, and the tear appears on that border near one of
// the fingers, at a junction between the curved region and a hand's flat one (paper §7.1), on two meshes.
TEST(Scenarios, Fig12StartsOnTheFlattenedBorderNearAFinger) {
  for (const int seed : {0, 1}) {
    const Scenario s = scenario_on_mesh("fig12-junction.json", seed);
    ScenarioRun r = run_scenario(s);
    ASSERT_FALSE(r.sheet().tears.empty()) << "seed " << seed;
    const Tear& first = r.sheet().tears[0];
    EXPECT_EQ(first.start_kind, StartKind::Junction) << "seed " << seed;
    EXPECT_NEAR(first.start_uv.y(), 0.0, 1e-9) << "on the bottom border, seed " << seed;
    double nearest = 1e9;
    for (const FingerSpec& f : s.fingers) nearest = std::min(nearest, (first.start_uv - f.at).norm());
    EXPECT_LT(nearest, 0.025) << "seed " << seed;
    for (const Finger& f : r.sheet().fingers) EXPECT_EQ(f.slips, 0) << "seed " << seed << " finger " << f.name;
  }
}

// A pinching finger starts one tear from its point, not a fan of them: on four meshes of start-finger no
// two tears leave one pattern point less than 30 degrees apart. (A finger's point exempt from the shielding
// of the tip it has just made starts two more tears there on mesh 3, in the same frame, 1 and 22 degrees
// from the first: slivers of paper 4 mm long.)
TEST(Scenarios, AFingerStartsNoSlivers) {
  for (const int seed : {0, 1, 2, 3}) {
    const Scenario s = scenario_on_mesh("start-finger.json", seed);
    ScenarioRun r = run_scenario(s);
    const std::vector<Tear>& tears = r.sheet().tears;
    EXPECT_FALSE(tears.empty()) << "seed " << seed;
    for (const Tear& b : tears) {
      if (b.tips.size() < 2) continue;
      const Vec2 leaves = (b.tips[1] - b.tips[0]).normalized();
      for (const Tear& a : tears) {
        if (a.id == b.id) continue;
        for (size_t i = 0; i < a.tips.size(); ++i) {
          if ((a.tips[i] - b.tips[0]).norm() > 1e-9) continue;
          for (const size_t j : {i + 1, i - 1}) {
            if (j >= a.tips.size()) continue;  // i − 1 wraps at the start
            const double angle = std::acos(std::clamp(leaves.dot((a.tips[j] - a.tips[i]).normalized()), -1.0, 1.0));
            EXPECT_GT(angle, 30.0 * std::numbers::pi / 180) << "seed " << seed << ": tears " << a.id << ", " << b.id;
          }
        }
      }
    }
    expect_no_violations(*r.sim);
  }
}

// Fig. 18: the sheet bent into a U, one hand slid along it, then the hands turned apart. The paper's tear
// starts at a singular point of the border as the hands move apart, without shredding. Over four meshes: at
// most 3 tears and 2 pieces on each, and on at least three the longest tear starts on the top border
// between the hands once they move apart (from 2.5 s). Disabled: with the compression relief the turn
// apart loads the diagonal between L1 and R2 alone, the fingers reach their grip and slip (208 slips over
// the four meshes), and one mesh tears so: 22 cm from a junction of the top border between the hands, 2
// pieces; another makes a 9 mm tear by the left hand (docs/tearing.md, "Known gaps"). With the stiff
// compression three of them tore from the border, after 111 slips.
TEST(Scenarios, DISABLED_Fig18TearsFromTheBorderBetweenTheHandsWithoutShredding) {
  int from_the_border = 0;
  for (const int seed : {0, 1, 2, 3}) {
    const Scenario s = scenario_on_mesh("fig18-crumple.json", seed);
    ScenarioRun r = run_scenario(s);
    const Sheet& sheet = r.sheet();
    EXPECT_LE(sheet.tears.size(), 3u) << "seed " << seed;
    EXPECT_LE(sheet.topo.piece_count, 2) << "seed " << seed;
    expect_no_violations(*r.sim);
    const Tear* longest = nullptr;
    for (const Tear& t : sheet.tears)
      if (!longest || path_length(t.tips) > path_length(longest->tips)) longest = &t;
    if (!longest) continue;
    const bool on_top_border = std::abs(longest->start_uv.y() - 0.21) < 1e-9;
    const bool between = between_the_hands(s, longest->start_uv);
    const bool apart = longest->start_frame >= static_cast<int32_t>(std::lround(2.5 * s.sim.fps));
    if (on_top_border && between && apart) ++from_the_border;
  }
  EXPECT_GE(from_the_border, 3);
}

// Fig. 17: fingers change positions during the tear. The second pair, put on at 2 s where the sheet
// hangs, tears on from the first pair's tip in another direction: by the bisector of its two fingers'
// bearings from that tip, 37° off the first run. On two meshes: one tear, its run after 2 s at least
// 2 cm and turned by more than 0.4 rad from the run before.
TEST(Scenarios, Fig17SecondPairTearsOnInAnotherDirection) {
  for (const int seed : {0, 1}) {
    const Scenario s = scenario_on_mesh("fig17-branching.json", seed);
    EngineOptions o;
    o.threads = 1;
    Simulation sim(s, o);
    const int32_t second_pair = static_cast<int32_t>(std::lround(2.0 * s.sim.fps));
    for (int32_t f = 0; f < second_pair; ++f) sim.step();
    ASSERT_EQ(sim.sheet().tears.size(), 1u) << "seed " << seed;
    const Vec2 first_start = sim.sheet().tears[0].tips.front(), kink = sim.sheet().tears[0].tips.back();
    for (int32_t f = second_pair; f < s.sim.frames; ++f) sim.step();
    ASSERT_EQ(sim.sheet().tears.size(), 1u) << "seed " << seed;
    const Vec2 end = sim.sheet().tears[0].tips.back();
    const Vec2 before = (kink - first_start).normalized(), after = end - kink;
    EXPECT_GT(after.norm(), 0.02) << "seed " << seed;
    EXPECT_GT(std::acos(std::clamp(before.dot(after.normalized()), -1.0, 1.0)), 0.4) << "seed " << seed;
    for (const Finger& f : sim.sheet().fingers) EXPECT_EQ(f.slips, 0) << "seed " << seed << " finger " << f.name;
  }
}

// Fig. 17: a tear branches from a split vertex of another: a parent link.
// Not met: fig17-branching's second pair tears on from the first tear's tip; a tear starting at the kink
// it leaves (an inward corner) needs a third pair whose tension wraps around the kink, and with the
// bearings from it nearly opposite such a pair releases almost nothing (Er ∝ cos(θ/2)).
TEST(Scenarios, DISABLED_BranchingGivesTearsWithAParent) {
  const Scenario s = load_scenario(scenario_path("fig17-branching.json"));
  ScenarioRun r = run_scenario(s);
  int with_parent = 0;
  for (const Tear& t : r.sheet().tears) {
    if (t.parent < 0) continue;
    ++with_parent;
    ASSERT_LT(t.parent, static_cast<int32_t>(r.sheet().tears.size()));
    EXPECT_LT(t.parent, t.id) << "a parent exists before its branch";
  }
  EXPECT_GE(r.sheet().tears.size(), 2u);
  EXPECT_GE(with_parent, 1);
}

// Fig. 16 (bottom): rotating the hands alternately zigzags the tear. Not met yet: 1 change beyond 0.2 rad
// on this mesh, 0–11 on 16 meshes, and the direction of the tear's growth during each hand phase does not
// alternate with the hands: the count measures the direction noise, not the hands.
TEST(Scenarios, DISABLED_ZigzagHasThreeDirectionChanges) {
  const Scenario s = load_scenario(scenario_path("fig16-zigzag.json"));
  ScenarioRun r = run_scenario(s);
  ASSERT_FALSE(r.sheet().tears.empty());
  const int changes = direction_changes(r.sheet().tears[0].tips, 0.2);
  std::printf("zigzag: %d direction changes beyond 0.2 rad\n", changes);
  EXPECT_GE(changes, 3);
}

// A sheet torn in two: two pieces that both keep falling and swinging.
TEST(Scenarios, TornInTwoGivesPiecesThatKeepMoving) {
  const Scenario s = load_scenario(scenario_path("torn-in-two.json"));
  ScenarioRun r = run_scenario(s);
  const Sheet& sheet = r.sheet();
  ASSERT_GE(sheet.topo.piece_count, 2);
  // The two largest pieces, by pattern area.
  std::vector<double> area(sheet.topo.piece_count, 0.0);
  for (int32_t t = 0; t < sheet.tris.size(); ++t) area[sheet.tris.piece[t]] += sheet.tris.rest_area[t];
  std::vector<int32_t> order(area.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int32_t>(i);
  std::sort(order.begin(), order.end(), [&](int32_t a, int32_t b) { return area[a] > area[b]; });
  const double total = total_rest_area(sheet.tris);
  ASSERT_GT(area[order[1]], 0.1 * total) << "the second piece is a real piece, not a sliver";
  auto centroid = [&](int32_t piece) {
    Vec3 c = Vec3::Zero();
    double w = 0;
    for (int32_t t = 0; t < sheet.tris.size(); ++t) {
      if (sheet.tris.piece[t] != piece) continue;
      for (int32_t v : sheet.tris.tri[t]) c += sheet.tris.rest_area[t] * sheet.verts.x[v];
      w += 3 * sheet.tris.rest_area[t];
    }
    return Vec3(c / w);
  };
  const Vec3 c0 = centroid(order[0]), c1 = centroid(order[1]);
  for (int f = 0; f < 10; ++f) r.sim->step();
  // Piece ids are recomputed after every topology change; the order by area is stable here.
  // Both fingers let go at 4.5 s: each piece falls under gravity (−z) and keeps swinging.
  EXPECT_LT(centroid(order[0]).z() - c0.z(), -1e-3) << "the first piece falls";
  EXPECT_LT(centroid(order[1]).z() - c1.z(), -1e-3) << "the second piece falls";
  expect_no_violations(*r.sim);
  EXPECT_TRUE(all_finite(r.sheet()));
}
