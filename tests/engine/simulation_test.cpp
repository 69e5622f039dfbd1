// The engine's frame (docs/architecture.md "The frame") seen from outside: after every step the sheet is
// in the state the graph's order leaves it, and each sim.relaxation mode does what docs/scenario-format.md
// promises. Everything is checked against what the systems compute from the sheet itself, not a hash.
#include "engine/result_writer.hpp"
#include "engine/scenario.hpp"
#include "engine/simulation.hpp"
#include "engine/simulation_internals.hpp"
#include "systems/physics/bending_forces.hpp"
#include "systems/physics/fingers.hpp"
#include "systems/tearing/candidates.hpp"
#include "systems/physics/membrane_forces.hpp"
#include "systems/tearing/regions.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

using namespace pt;

namespace {

Scenario fig14(const std::string& relaxation = "substep") {
  Scenario s = load_scenario(std::string(PT_SOURCE_DIR) + "/scenarios/fig14-straight.json");
  s.sim.relaxation = relaxation;
  return s;
}

EngineOptions one_thread() {
  EngineOptions o;
  o.threads = 1;
  o.check_invariants = true;
  return o;
}

// The internal forces of the sheet's current positions, as the forces system computes them (membrane
// corner forces, with the fingers' pinches, gathered per vertex, then bending), in one range: the engine's
// kernels run one range on a sheet no larger than parallel_grain, so the sums are the same bits.
std::vector<Vec3> forces_of(const Sheet& s) {
  std::vector<double> pinched;
  mark_pinched_triangles(s.fingers, s.verts.rest, s.tris.tri, s.topo, kFingertipRadius, pinched);
  std::vector<std::array<Vec3, 3>> corner(s.tris.size());
  compute_membrane_forces(s.verts.x, s.tris.tri, s.tris.rest_inv, s.tris.rest_area, pinched,
                          membrane_params(s.material), 0, s.tris.size(), corner);
  std::vector<Vec3> force(s.verts.size());
  gather_corner_forces(s.topo, s.tris.tri, corner, 0, s.verts.size(), force);
  std::vector<BendingStencil> bending;
  build_bending_stencils(s.verts.rest, s.topo.hinges, bending_stiffness(s.material), bending);
  add_bending_forces(s.verts.x, bending, force);
  return force;
}

int32_t segments(const Tear& t) { return static_cast<int32_t>(t.tips.size()) - 1; }

// Whole-sheet implicit substeps the run took: one numeric factorisation each, plus one per spin-brake redo
// and two per split (the step tried whole, then its two halves; a half's own split counts again; the runs
// below need no regularised retry, which would add more).
int64_t sheet_substeps(const Simulation& sim) {
  const ImplicitStats st = solver_stats(sim);
  EXPECT_EQ(st.regularised, 0);
  EXPECT_EQ(st.failures, 0);
  return st.factorizations - st.brakes - 2 * st.splits;
}

}  // namespace

// fingers ─▶ physics ─▶ forces ─▶ regions ─▶ candidates ─▶ tearing step, carving of the earlier frames'
// segments beside them. Each frame of Fig. 14 (a notch torn by two fingers pulled apart) ends with
// - every held finger's vertex at the finger's target of the frame's end: the fingers moved before the
//   physics, which prescribes the held vertices to the targets;
// - the sheet's forces those of its final positions: forces ran after the physics (and after each cut's
//   relaxation), never before it;
// - on frames without a cut, the region labels those of the final positions and the candidates those the
//   final flags give: regions ran after the physics, candidates after the regions;
// - each tear carved up to the segments it had when the frame began: carving ran beside this frame's
//   physics on the earlier frames' segments, and this frame's wait for the next frame or flush();
// - the frame's events stamped with its own number.
TEST(Simulation, FrameRunsItsSystemsInTheGraphsOrder) {
  const Scenario s = fig14();
  Simulation sim(s, one_thread());
  std::vector<int32_t> segments_before;  // per tear, at the start of the frame
  std::vector<Vec3> targets_before;
  size_t events_before = 0;
  int held_checked = 0, moved_targets = 0, quiet_frames = 0, frames_with_cuts = 0, carving_lags = 0;
  for (int32_t f = 0; f < s.sim.frames; ++f) {
    segments_before.clear();
    for (const Tear& t : sim.sheet().tears) segments_before.push_back(segments(t));
    targets_before.clear();
    for (const Finger& finger : sim.sheet().fingers) targets_before.push_back(finger.target);
    const int32_t remeshes_before = sim.remesh_count();
    sim.step();
    const Sheet& sheet = sim.sheet();
    ASSERT_TRUE(sim.stop_reason().empty()) << sim.stop_reason();

    for (size_t i = 0; i < sheet.fingers.size(); ++i) {
      const Finger& finger = sheet.fingers[i];
      if (finger.vertex < 0 || finger.slipping) continue;
      EXPECT_EQ(sheet.verts.x[finger.vertex], finger.target + finger.hold_offset) << "frame " << f << " finger " << i;
      ++held_checked;
      if (i < targets_before.size() && finger.target != targets_before[i]) ++moved_targets;
    }

    ASSERT_LE(sheet.tris.size(), EngineOptions{}.parallel_grain) << "frame " << f << ": forces_of assumes one range";
    ASSERT_LE(sheet.verts.size(), EngineOptions{}.parallel_grain) << "frame " << f;
    const std::vector<Vec3> force = forces_of(sheet);
    ASSERT_EQ(force.size(), sheet.verts.force.size());
    for (int32_t v = 0; v < sheet.verts.size(); ++v)
      ASSERT_EQ(sheet.verts.force[v], force[v]) << "frame " << f << " vertex " << v;

    if (sim.remesh_count() == remeshes_before) {
      ++quiet_frames;
      std::vector<int32_t> region = sheet.tris.region;
      std::vector<Region> regions;
      std::vector<uint8_t> flags = sheet.verts.flags;
      classify_regions(sheet.verts.x, sheet.tris.tri, sheet.topo, RegionParams{}, region, regions, flags);
      EXPECT_EQ(region, sheet.tris.region) << "frame " << f;
      EXPECT_EQ(flags, sheet.verts.flags) << "frame " << f;
      std::vector<Candidate> listed;
      FiberSampleCache cache;
      find_candidates(sheet.verts, sheet.topo.boundary_vertices, sheet.tips, sheet.fingers, sheet.tears, sheet.material,
                      fiber_field(sim), listed, cache);
      ASSERT_EQ(listed.size(), tearing_candidates(sim).size()) << "frame " << f;
      for (size_t c = 0; c < listed.size(); ++c) {
        EXPECT_EQ(listed[c].vertex, tearing_candidates(sim)[c].vertex) << "frame " << f;
        EXPECT_EQ(listed[c].kind, tearing_candidates(sim)[c].kind) << "frame " << f;
        EXPECT_EQ(listed[c].fracture_energy, tearing_candidates(sim)[c].fracture_energy) << "frame " << f;
      }
    } else {
      ++frames_with_cuts;
    }

    for (size_t t = 0; t < sheet.tears.size(); ++t) {
      const int32_t at_start = t < segments_before.size() ? segments_before[t] : 0;
      EXPECT_EQ(sheet.tears[t].carved_segments, at_start) << "frame " << f << " tear " << t;
      if (segments(sheet.tears[t]) > at_start) ++carving_lags;
    }

    for (size_t e = events_before; e < sim.events().size(); ++e) EXPECT_EQ(sim.events()[e].frame, f);
    events_before = sim.events().size();
  }
  sim.flush();
  for (const Tear& t : sim.sheet().tears) EXPECT_EQ(t.carved_segments, segments(t)) << "flush carves the rest";
  for (const std::string& v : sim.invariant_violations()) ADD_FAILURE() << v;
  // The checks above ran on frames of each kind.
  EXPECT_GT(held_checked, s.sim.frames);
  EXPECT_GT(moved_targets, s.sim.frames / 2);
  EXPECT_GT(quiet_frames, 10);
  EXPECT_GT(frames_with_cuts, 3);
  EXPECT_GT(carving_lags, 3);
  EXPECT_FALSE(sim.sheet().tears.empty());
}

// "substep": every cut is followed by one more substep of the whole sheet, and the frame's other
// candidates are treated after it. A frame whose last substep stopped for a cut runs that substep once
// more to the frame's end (docs/tearing.md "Quasi-static tearing"): at most one more, and only with a cut.
TEST(Simulation, SubstepRelaxationRunsOneWholeSheetSubstepPerCut) {
  const Scenario s = fig14("substep");
  Simulation sim(s, one_thread());
  int frames_with_cuts = 0;
  for (int32_t f = 0; f < s.sim.frames; ++f) {
    const int32_t cuts = sim.remesh_count();
    const int64_t before = sheet_substeps(sim);
    sim.step();
    const int32_t made = sim.remesh_count() - cuts;
    if (made > 0) {
      ++frames_with_cuts;
      EXPECT_GT(sim.last_profile().relaxation, 0.0) << "frame " << f;
    }
    const int64_t extra = sheet_substeps(sim) - before - s.sim.substeps - made;
    EXPECT_GE(extra, 0) << "frame " << f;
    EXPECT_LE(extra, made > 0 ? 1 : 0) << "frame " << f;
  }
  EXPECT_GT(frames_with_cuts, 3);
}

// "next_frame": no relaxation substep; the next frame's physics relaxes the cut, so a frame makes at most
// one propagation.
TEST(Simulation, NextFrameRelaxationCutsAtMostOncePerFrameWithoutAnExtraSubstep) {
  const Scenario s = fig14("next_frame");
  Simulation sim(s, one_thread());
  int frames_with_cuts = 0;
  for (int32_t f = 0; f < s.sim.frames; ++f) {
    const int32_t cuts = sim.remesh_count();
    sim.step();
    EXPECT_LE(sim.remesh_count() - cuts, 1) << "frame " << f;
    if (sim.remesh_count() > cuts) ++frames_with_cuts;
    EXPECT_EQ(sim.last_profile().relaxation, 0.0) << "frame " << f;
    EXPECT_EQ(sheet_substeps(sim), int64_t{f + 1} * s.sim.substeps) << "frame " << f;
  }
  EXPECT_GT(frames_with_cuts, 3);
}

// "patch": after each cut a substep relaxes only the patch around the tear (its own small system), so
// the whole sheet's solver takes the frames' substeps (and the rerun of a last substep that stopped for
// a cut) and nothing more, while each frame with a cut spends time relaxing.
TEST(Simulation, PatchRelaxationLeavesTheWholeSheetsSolverToTheFrames) {
  const Scenario s = fig14("patch");
  Simulation sim(s, one_thread());
  int frames_with_cuts = 0;
  for (int32_t f = 0; f < s.sim.frames; ++f) {
    const int32_t cuts = sim.remesh_count();
    const int64_t before = sheet_substeps(sim);
    sim.step();
    const bool cut = sim.remesh_count() > cuts;
    if (cut) {
      ++frames_with_cuts;
      EXPECT_GT(sim.last_profile().relaxation, 0.0) << "frame " << f;
    }
    const int64_t extra = sheet_substeps(sim) - before - s.sim.substeps;
    EXPECT_GE(extra, 0) << "frame " << f;
    EXPECT_LE(extra, cut ? 1 : 0) << "frame " << f;
  }
  // The patch relaxation leaves the fingers' pull where it was, so the tear runs through in the frame it
  // starts (docs/tearing.md, known gaps): that frame's cuts each add at most the one rerun substep.
  EXPECT_GE(frames_with_cuts, 1);
  EXPECT_GT(sim.remesh_count(), 3);
  for (const std::string& v : sim.invariant_violations()) ADD_FAILURE() << v;
}

// A hand whose fingers are put on later (fingers[].attach) moves them from where they grab the sheet,
// which by then hangs elsewhere than its pattern: its rotation turns them rigidly about the centroid of
// the grabbed points (docs/scenario-format.md), not about that of their pattern points.
TEST(Simulation, AHandPutOnLaterTurnsAboutWhereItGrabs) {
  Scenario s = parse_scenario(R"({
    "sheet": {"preset": "A6", "triangles": 120},
    "sim": {"frames": 30, "fps": 30},
    "fingers": [{"name": "A", "at": [0.05, 0.14]},
                {"name": "C", "at": [0.03, 0.05], "attach": 0.5}, {"name": "D", "at": [0.07, 0.05], "attach": 0.5}],
    "hands": [{"name": "lower", "fingers": ["C", "D"],
               "keys": [[0.5, {"rotate_deg": 0, "axis": [0, 1, 0]}], [1.0, {"rotate_deg": 90, "axis": [0, 1, 0]}]]}]
  })", "hand-put-on-later.json");
  Simulation sim(s, one_thread());
  for (int f = 0; f < 16; ++f) sim.step();  // the finger grabs at the frame starting at t = 0.5
  const Sheet& sh = sim.sheet();
  const Finger& c = sh.fingers[1];
  const Finger& d = sh.fingers[2];
  ASSERT_GE(c.vertex, 0);
  ASSERT_GE(d.vertex, 0);
  EXPECT_GT((c.start - Vec3(0.03, 0.05, 0)).norm(), 0.01) << "the sheet hangs: C grabs away from its pattern point";
  const Vec3 centroid = 0.5 * (c.start + d.start);
  EXPECT_NEAR((sh.hands[0].centroid - centroid).norm(), 0, 1e-15);
  for (int f = 16; f < 30; ++f) sim.step();
  // Turned by 90° about the grabbed centroid: the same distance apart and from it, the centroid in place.
  EXPECT_NEAR((c.target - d.target).norm(), (c.start - d.start).norm(), 1e-12);
  EXPECT_NEAR((0.5 * (c.target + d.target) - centroid).norm(), 0, 1e-12);
  const Vec3 y(0, 1, 0), across = (c.start - centroid) - (c.start - centroid).dot(y) * y;
  EXPECT_NEAR((c.target - centroid).dot(across), 0, 1e-12) << "a quarter turn about y";
  EXPECT_NEAR((c.target - centroid).dot(y), (c.start - centroid).dot(y), 1e-12);
}

// Triangles::pinched is rebuilt only when the topology or a finger's hold changes; after every frame it is
// what the fingers holding then give, through a pad, a hand put on later and a finger letting go.
TEST(Simulation, PinchesFollowTheFingersThatHold) {
  Scenario s = parse_scenario(R"({
    "sheet": {"preset": "A6", "triangles": 120},
    "sim": {"frames": 24, "fps": 30},
    "fingers": [{"name": "A", "at": [0.05, 0.14], "pad": 0.008, "release": 0.6},
                {"name": "C", "at": [0.03, 0.05], "attach": 0.3}, {"name": "D", "at": [0.07, 0.05], "attach": 0.3}],
    "hands": [{"name": "lower", "fingers": ["C", "D"],
               "keys": [[0.3, {"rotate_deg": 0, "axis": [0, 1, 0]}], [0.8, {"rotate_deg": 60, "axis": [0, 1, 0]}]]}]
  })", "pinches-follow.json");
  Simulation sim(s, one_thread());
  std::vector<double> fresh;
  int holds_seen = 0;  // distinct sets of holding fingers met: A alone, A with C and D, C and D
  std::vector<bool> last_holding;
  for (int f = 0; f < 24; ++f) {
    sim.step();
    const Sheet& sh = sim.sheet();
    mark_pinched_triangles(sh.fingers, sh.verts.rest, sh.tris.tri, sh.topo, kFingertipRadius, fresh);
    ASSERT_EQ(sh.tris.pinched, fresh) << "frame " << f;
    std::vector<bool> holding;
    for (const Finger& finger : sh.fingers) holding.push_back(finger.vertex >= 0);
    if (holding != last_holding) ++holds_seen;
    last_holding = holding;
  }
  EXPECT_EQ(holds_seen, 3);
}

namespace {

// A 10 cm × 2 cm strip without gravity held by one finger 1 cm from its end, whose hand turns 20° about
// the y axis through the finger: `pad` is the finger's pad radius.
Scenario turned_strip(double pad) {
  const std::string json = R"({"name": "turned-strip",
    "sheet": {"outline": [[0, 0], [0.1, 0], [0.1, 0.02], [0, 0.02]], "triangles": 80},
    "sim": {"frames": 60, "gravity": [0, 0, 0]},
    "fingers": [{"name": "A", "at": [0.01, 0.01], "pad": )" + std::to_string(pad) + R"(}],
    "hands": [{"name": "h", "fingers": ["A"], "keys": [[0, {"rotate_deg": 0, "axis": [0, 1, 0]}],
                                                        [0.5, {"rotate_deg": -20, "axis": [0, 1, 0]}]]}]})";
  return parse_scenario(json, "turned-strip.json");
}

}  // namespace

// A pad (systems/physics/fingers.hpp) holds the disc of its radius: the ring the builder meshes lies on it
// on every mesh, and every vertex of the pad lies within it.
TEST(Simulation, APadHoldsItsDiscOnEveryMesh) {
  for (const uint64_t seed : {0, 1, 2}) {
    Scenario s = turned_strip(0.006);
    s.mesh_seed = seed;
    s.mesh_rotation_deg = 17.0 * double(seed);
    Simulation sim(s, one_thread());
    const Finger& f = sim.sheet().fingers[0];
    const auto& rest = sim.sheet().verts.rest;
    // The ring points 1 cm from the end are 4 mm from the long sides: all but none are kept (six).
    int on_ring = 0;
    for (int32_t v : f.pad) {
      const double d = (rest[v] - f.uv).norm();
      EXPECT_LE(d, 0.006 * (1 + 1e-9)) << "seed " << seed;
      on_ring += std::abs(d - 0.006) < 1e-9;
    }
    EXPECT_EQ(on_ring, 6) << "seed " << seed;
    EXPECT_EQ(f.pad.size(), f.pad_offset.size());
  }
}

// A point cannot be turned: a hand turning about the line through its only finger leaves the strip flat.
// A pad turns the paper it pinches, and a strip with no load turns with it as a rigid body: its far end
// rises to 9 cm × sin 20°. The pad's reaction is the sum over its vertices, which balance: no load, no force.
TEST(Simulation, APadTurnsWithItsHandWhereAPointCannot) {
  auto far_end_z = [](double pad, double& force) {
    const Scenario s = turned_strip(pad);
    Simulation sim(s, one_thread());
    for (int32_t f = 0; f < s.sim.frames; ++f) sim.step();
    const Sheet& sheet = sim.sheet();
    double z = 0;
    int n = 0;
    for (size_t v = 0; v < sheet.verts.rest.size(); ++v)
      if (sheet.verts.rest[v].x() > 0.1 - 1e-9) z += sheet.verts.x[v].z(), ++n;
    force = sheet.fingers[0].reaction.norm();
    return z / n;
  };
  double force = 0;
  EXPECT_NEAR(far_end_z(0, force), 0, 1e-6);
  EXPECT_NEAR(far_end_z(0.006, force), 0.09 * std::sin(20 * std::numbers::pi / 180), 0.002);
  EXPECT_LT(force, 1e-3);
}

// Cuts renumber vertices (remeshing's compaction): a pad keeps holding the same paper, its vertices
// within its radius of the finger's point in the pattern, at their targets, frame after frame while the
// tear runs; and none of them is removed by a cut.
TEST(Simulation, APadKeepsItsPaperThroughCuts) {
  for (const uint64_t seed : {0, 1, 2, 3}) {
    Scenario s = load_scenario(std::string(PT_SOURCE_DIR) + "/scenarios/fig14-straight.json");
    s.mesh_seed = seed;
    s.mesh_rotation_deg = 17.0 * double(seed);
    std::vector<size_t> pad_size;
    for (FingerSpec& f : s.fingers) f.pad = 0.006;
    Simulation sim(s, one_thread());
    for (const Finger& f : sim.sheet().fingers) pad_size.push_back(f.pad.size());
    for (int32_t frame = 0; frame < s.sim.frames; ++frame) {
      sim.step();
      const Sheet& sheet = sim.sheet();
      for (size_t i = 0; i < sheet.fingers.size(); ++i) {
        const Finger& f = sheet.fingers[i];
        ASSERT_EQ(f.pad.size(), pad_size[i]) << "seed " << seed << " frame " << frame;
        for (int32_t v : f.pad) {
          ASSERT_LT(v, sheet.verts.size());
          EXPECT_LE((sheet.verts.rest[v] - f.uv).norm(), 0.006 * (1 + 1e-9)) << "seed " << seed << " frame " << frame;
        }
      }
    }
    EXPECT_FALSE(sim.sheet().tears.empty()) << "seed " << seed;
    for (const std::string& v : sim.invariant_violations()) ADD_FAILURE() << v;
  }
}

// The pattern SVG draws a pad's disc: a ring of its radius (1 000 units a metre) around the finger's dot.
TEST(Simulation, ThePatternShowsAPadsDisc) {
  Simulation sim(turned_strip(0.006), one_thread());
  auto svg_of = [](const Simulation& sim) {
    const std::string path = testing::TempDir() + "pad-pattern.svg";
    write_svg(sim, path);
    std::ifstream in(path);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  const std::string svg = svg_of(sim);
  const size_t ring = svg.find("<circle class=\"pad\"");
  ASSERT_NE(ring, std::string::npos);
  EXPECT_NE(svg.find("r=\"6.000\"", ring), std::string::npos);
  EXPECT_EQ(svg.find("<circle class=\"pad\"", ring + 1), std::string::npos) << "one finger, one ring";
  EXPECT_EQ(svg_of(Simulation(turned_strip(0), one_thread())).find("class=\"pad\""), std::string::npos)
      << "a point has no ring";
}

// max_strain_beyond_tips reads the triangles that come no nearer than 5 mm (pattern) to an active tip or to
// an inward corner of the outline no tear has started from: a notch's end is a crack tip that has not moved
// yet, and its strain is singular. On fig21-notch before it tears, recomputed here after every frame from
// the triangles' strains and their distances to the outline's inward corners (an independent reading of
// the rule), the running maximum is the engine's, and the corner's triangles are the most stretched.
TEST(Simulation, StrainBeyondTheTipsLeavesOutTheNotchCornersZone) {
  Scenario s = load_scenario(std::string(PT_SOURCE_DIR) + "/scenarios/fig21-notch.json");
  Simulation sim(s, one_thread());
  std::vector<Vec2> corners;
  for (int32_t v = 0; v < sim.sheet().verts.size(); ++v)
    if (sim.sheet().verts.flags[v] & kInward) corners.push_back(sim.sheet().verts.rest[v]);
  ASSERT_FALSE(corners.empty());
  auto distance = [](const Vec2& p, const Vec2& a, const Vec2& b, const Vec2& c) {
    auto cross = [](const Vec2& u, const Vec2& w) { return u.x() * w.y() - u.y() * w.x(); };
    const double s0 = cross(b - a, p - a), s1 = cross(c - b, p - b), s2 = cross(a - c, p - c);
    if ((s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0)) return 0.0;
    auto segment = [](const Vec2& q, const Vec2& u, const Vec2& w) {
      const double t = std::clamp((q - u).dot(w - u) / (w - u).squaredNorm(), 0.0, 1.0);
      return (u + t * (w - u) - q).norm();
    };
    return std::min({segment(p, a, b), segment(p, b, c), segment(p, c, a)});
  };
  double beyond = 0, all = 0;
  for (int f = 0; f < 24; ++f) {
    sim.step();
    ASSERT_TRUE(sim.sheet().tears.empty()) << "frame " << f << ": the notch tore before the test's frames";
    const Sheet& sh = sim.sheet();
    for (int32_t t = 0; t < sh.tris.size(); ++t) {
      const double e = max_principal_strain(sh.verts.x, sh.tris.tri, sh.tris.rest_inv, t, t + 1);
      all = std::max(all, e);
      const Tri& c = sh.tris.tri[t];
      bool near_corner = false;
      for (const Vec2& p : corners)
        near_corner = near_corner || distance(p, sh.verts.rest[c[0]], sh.verts.rest[c[1]], sh.verts.rest[c[2]]) < 0.005;
      if (!near_corner) beyond = std::max(beyond, e);
    }
  }
  EXPECT_DOUBLE_EQ(sim.max_strain(), all);
  EXPECT_DOUBLE_EQ(sim.max_strain_beyond_tips(), beyond);
  EXPECT_LT(beyond, all);
}
