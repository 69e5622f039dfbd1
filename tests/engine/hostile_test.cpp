// Hostile motions (issue 9): fingers pulled far beyond the sheet, fingers crossing each other, zero-length
// and reversed keys, every finger released in the middle of a tear, a sheet cut into many small pieces,
// tears meeting each other or the boundary at grazing angles. The engine keeps going or stops with a
// clear error (one line); it never crashes, hangs (each case well under 60 s) or produces a NaN; the state
// hash is the same at 1 and 2 threads. The invariants of docs/architecture.md "Data and its invariants" are
// checked after every remesh.
// The soak (`make soak`, 10 000 frames of tests/soak/soak.json) is a program: tools/soak.cpp.
#include "engine/batch.hpp"
#include "engine/result_writer.hpp"
#include "engine/scenario.hpp"
#include "engine/simulation.hpp"
#include "engine/simulation_internals.hpp"
#include "systems/mesh/meshing.hpp"
#include "systems/mesh/remeshing.hpp"
#include "systems/common/topology.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <iterator>
#include <limits>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

using namespace pt;

namespace {

using Clock = std::chrono::steady_clock;
constexpr double kCaseSeconds = 60;

// A 0.1 m square with a notch in the middle of the top edge.
const char* kNotched = R"([[0,0],[0.1,0],[0.1,0.1],[0.052,0.1],[0.05,0.088],[0.048,0.1],[0,0.1]])";

std::string scene(const std::string& name, const std::string& fingers, int frames, const std::string& extra = "",
                  const char* outline = kNotched, int triangles = 200) {
  std::ostringstream o;
  o << R"({"name": ")" << name << R"(", "sheet": {"outline": )" << outline << R"(, "triangles": )" << triangles
    << R"(}, "sim": {"frames": )" << frames << R"(}, "fingers": )" << fingers << extra << "}";
  return o.str();
}

bool all_finite(const Sheet& s, std::string& where) {
  where = first_non_finite(s);
  return where.empty();
}

struct Outcome {
  std::string hash;
  std::string error;  // what the engine threw, "" when it kept going
  int32_t frames = 0, triangles = 0, pieces = 0, tears = 0;
  double seconds = 0;
};

// Runs `frames` frames; `between(sim, frame)` may act on the simulation before each frame. Checks every
// frame for non-finite values; collects invariant violations.
Outcome run(const Scenario& sc, int frames, int threads,
            const std::function<void(Simulation&, int)>& between = {}) {
  Outcome out;
  const auto t0 = Clock::now();
  EngineOptions opt;
  opt.threads = threads;
  opt.check_invariants = true;
  try {
    Simulation sim(sc, opt);
    for (int f = 0; f < frames; ++f) {
      if (between) between(sim, f);
      sim.step();
      std::string where;
      if (!all_finite(sim.sheet(), where)) {
        ADD_FAILURE() << sc.name << ": non-finite value at frame " << f << " (" << where << ")";
        break;
      }
      const double elapsed = std::chrono::duration<double>(Clock::now() - t0).count();
      if (elapsed > kCaseSeconds) {
        ADD_FAILURE() << sc.name << ": frame " << f << " after " << elapsed << " s (limit " << kCaseSeconds << " s)";
        break;
      }
      out.frames = f + 1;
    }
    sim.flush();
    std::string where;
    EXPECT_TRUE(all_finite(sim.sheet(), where)) << sc.name << ": " << where;
    for (const std::string& v : sim.invariant_violations()) ADD_FAILURE() << sc.name << ": invariant: " << v;
    out.hash = sim.state_hash();
    out.triangles = sim.sheet().tris.size();
    out.pieces = sim.sheet().topo.piece_count;
    out.tears = static_cast<int32_t>(sim.sheet().tears.size());
  } catch (const InputError& e) {
    out.error = e.what();
  } catch (const GeometryError& e) {
    out.error = e.what();
  } catch (const std::exception& e) {
    out.error = std::string("internal: ") + e.what();
  }
  out.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  if (!out.error.empty()) {
    EXPECT_EQ(out.error.find('\n'), std::string::npos) << "error is not one line: " << out.error;
  }
  std::printf("  %-22s threads %d: %3d frames, %4d triangles, %2d pieces, %2d tears, %.2f s%s%s\n", sc.name.c_str(),
              threads, out.frames, out.triangles, out.pieces, out.tears, out.seconds,
              out.error.empty() ? "" : ", error: ", out.error.c_str());
  return out;
}

// The same case at 1 and 2 threads: same outcome, same hash; the engine did not throw an internal error.
Outcome run_both(const std::string& json, int frames, const std::function<void(Simulation&, int)>& between = {}) {
  const Scenario sc = parse_scenario(json, "hostile.json");
  const Outcome a = run(sc, frames, 1, between);
  const Outcome b = run(sc, frames, 2, between);
  EXPECT_EQ(a.hash, b.hash) << sc.name << ": state hash depends on the thread count";
  EXPECT_EQ(a.error, b.error);
  EXPECT_EQ(a.error.rfind("internal: ", 0), std::string::npos) << sc.name << ": " << a.error;
  EXPECT_LT(a.seconds, kCaseSeconds);
  EXPECT_LT(b.seconds, kCaseSeconds);
  return b;
}

std::string pair_apart(double dx, double dz, double t1) {
  std::ostringstream o;
  o << R"([{"name": "A", "at": [0.035, 0.09], "keys": [[0, [0.035, 0.09, 0]], [)" << t1 << ", [" << 0.035 - dx
    << ", 0.09, " << dz << R"(]]]},
           {"name": "B", "at": [0.065, 0.09], "keys": [[0, [0.065, 0.09, 0]], [)" << t1 << ", [" << 0.065 + dx
    << ", 0.09, " << -dz << "]]]}]";
  return o.str();
}

}  // namespace

TEST(Hostile, FingersPulledTenMetersAway) {
  // Both fingers leave for 10 m in 1 s (10 m/s), one of them also straight up.
  const std::string fingers = R"([
    {"name": "A", "at": [0.035, 0.09], "keys": [[0, [0.035, 0.09, 0]], [1, [-10, 0.09, 0]]]},
    {"name": "B", "at": [0.065, 0.09], "keys": [[0, [0.065, 0.09, 0]], [1, [10, 0.09, 10]]]}])";
  const Outcome o = run_both(scene("ten-meters", fingers, 45), 45);
  EXPECT_TRUE(o.error.empty() || o.error.find("internal") == std::string::npos);
}

TEST(Hostile, OneFingerTenMetersAwayInOneFrame) {
  // A jump of 10 m between two frames (keys 1/30 s apart), the other finger holds still.
  const std::string fingers = R"([
    {"name": "A", "at": [0.02, 0.05], "keys": [[0.5, [0.02, 0.05, 0]], [0.5333, [0.02, 0.05, 10]]]},
    {"name": "B", "at": [0.08, 0.05]}])";
  run_both(scene("jump", fingers, 40), 40);
}

TEST(Hostile, FingersCrossEachOther) {
  // A and B swap places through the same point at the same time, then go on past each other.
  const std::string fingers = R"([
    {"name": "A", "at": [0.03, 0.08], "keys": [[0, [0.03, 0.08, 0]], [0.5, [0.05, 0.08, 0.01]], [1.0, [0.09, 0.08, 0]]]},
    {"name": "B", "at": [0.07, 0.08], "keys": [[0, [0.07, 0.08, 0]], [0.5, [0.05, 0.08, 0.01]], [1.0, [0.01, 0.08, 0]]]},
    {"name": "C", "at": [0.05, 0.02]}])";
  run_both(scene("crossing", fingers, 45), 45);
}

TEST(Hostile, HandsCrossEachOther) {
  // Two hands rotate their fingers half a turn about the sheet's centre, in opposite senses.
  const std::string fingers = R"([{"name": "A", "at": [0.02, 0.05]}, {"name": "B", "at": [0.08, 0.05]},
                                  {"name": "C", "at": [0.05, 0.02]}, {"name": "D", "at": [0.05, 0.07]}])";
  const std::string hands = R"(, "hands": [
    {"name": "L", "fingers": ["A", "B"], "keys": [[0, {"rotate_deg": 0}], [1, {"rotate_deg": 180, "translate": [0, 0, 0.02]}]]},
    {"name": "R", "fingers": ["C", "D"], "keys": [[0, {"rotate_deg": 0}], [1, {"rotate_deg": -180, "axis": [0, 0, 1]}]]}])";
  run_both(scene("hands-crossing", fingers, 40, hands), 40);
}

TEST(Hostile, ZeroLengthKeys) {
  // Keys that do not move the finger (same position at successive times), and a single key.
  const std::string fingers = R"([
    {"name": "A", "at": [0.035, 0.09], "keys": [[0, [0.035, 0.09, 0]], [0.1, [0.035, 0.09, 0]], [0.2, [0.035, 0.09, 0]]]},
    {"name": "B", "at": [0.065, 0.09], "keys": [[0.3, [0.065, 0.09, 0]]]}])";
  const Outcome o = run_both(scene("zero-length", fingers, 20), 20);
  EXPECT_TRUE(o.error.empty()) << o.error;
}

TEST(Hostile, ReversedAndEqualKeyTimesAreInputErrors) {
  // In a file: a later key earlier in time, and two keys at the same time.
  for (const char* keys : {R"([[1.0, [0.035, 0.09, 0]], [0.5, [0.03, 0.09, 0]]])",
                           R"([[0.5, [0.035, 0.09, 0]], [0.5, [0.03, 0.09, 0]]])",
                           R"([[0.0, [0.035, 0.09, 0]], [1.0, [0.03, 0.09, 0]], [0.25, [0.03, 0.09, 0.1]]])"}) {
    const std::string fingers = std::string(R"([{"name": "A", "at": [0.035, 0.09], "keys": )") + keys + "}]";
    try {
      parse_scenario(scene("reversed", fingers, 10), "reversed.json");
      ADD_FAILURE() << "accepted " << keys;
    } catch (const InputError& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("reversed.json: fingers[0].keys["), std::string::npos) << m;
      EXPECT_NE(m.find("increase"), std::string::npos) << m;
    }
  }
  // Built in code: validate_scenario rejects them too, for fingers and hands, and Simulation does not start.
  Scenario sc = parse_scenario(scene("reversed", pair_apart(0.02, 0.05, 1.0), 10), "code");
  sc.fingers[0].keys = {FingerKey{1.0, Vec3(0.035, 0.09, 0)}, FingerKey{0.5, Vec3(0.03, 0.09, 0)}};
  EXPECT_THROW(validate_scenario(sc), InputError);
  EXPECT_THROW(Simulation{sc}, InputError);
  // A NaN target built in code: refused by the constructor too, instead of running to NaN positions.
  sc = parse_scenario(scene("nan-key", pair_apart(0.02, 0.05, 1.0), 10), "code");
  sc.fingers[1].keys[1].position.x() = std::nan("");
  EXPECT_THROW(Simulation{sc}, InputError);
  sc = parse_scenario(scene("reversed", pair_apart(0.02, 0.05, 1.0), 10), "code");
  sc.hands.push_back(HandSpec{"H", {"A"}, {HandKey{2.0}, HandKey{1.0}}});
  EXPECT_THROW(validate_scenario(sc), InputError);
  // Release before attach.
  sc = parse_scenario(scene("reversed", pair_apart(0.02, 0.05, 1.0), 10), "code");
  sc.fingers[0].attach = 1.0;
  sc.fingers[0].release = 0.5;
  EXPECT_THROW(validate_scenario(sc), InputError);
}

TEST(Hostile, EveryFingerReleasedMidTear) {
  // The torn-in-two pull; both fingers let go at 0.6 s while the tear runs; the sheet then falls freely.
  std::string fingers = pair_apart(0.03, 0.1, 1.5);
  std::string released;
  for (size_t i = 0; i < fingers.size(); ++i) {
    if (fingers.compare(i, 9, R"("keys": [)") == 0) released += R"("release": 0.6, )";
    released += fingers[i];
  }
  const Outcome o = run_both(scene("released-mid-tear", released, 60), 60);
  EXPECT_TRUE(o.error.empty()) << o.error;
  EXPECT_GE(o.tears, 1) << "the pull should have started a tear before the release";
}

TEST(Hostile, InteractiveFingersReleasedMidTearAndFlungAway) {
  // Through the interactive API: attach outside (refused), attach, drag 10 m, release everything.
  const Scenario sc = parse_scenario(scene("interactive", pair_apart(0.03, 0.1, 1.5), 60), "interactive.json");
  auto between = [](Simulation& sim, int frame) {
    if (frame == 5) {
      EXPECT_EQ(sim.attach_finger("outside", Vec2(0.5, 0.5)), -1);
      EXPECT_GE(sim.attach_finger("late", Vec2(0.05, 0.03)), 0);
    }
    if (frame == 10) sim.move_finger(2, Vec3(0.05, -10, 0));
    if (frame == 18)
      for (int32_t f = 0; f < static_cast<int32_t>(sim.sheet().fingers.size()); ++f) sim.release_finger(f);
    if (frame == 20) sim.release_finger(0);  // twice
  };
  const Outcome a = run(sc, 40, 1, between);
  const Outcome b = run(sc, 40, 2, between);
  EXPECT_EQ(a.hash, b.hash);
  EXPECT_TRUE(a.error.empty() && b.error.empty()) << a.error << b.error;
}

namespace {

// Cuts one straight tear from the boundary vertex closest to `from` towards `to` (clipped at the first
// boundary crossing), recording it as a tear of the sheet the way the engine does. Returns the cut.
CutResult cut_tear(Sheet& s, const Vec2& from, const Vec2& to, const Vec2& previous = Vec2::Zero()) {
  // Lip copies share their pattern position, and only one side may have a vertex near `from`: try the
  // boundary vertices within 4 mm, closest first, until one cuts into its own piece.
  std::vector<std::pair<double, int32_t>> near;
  for (int32_t v = 0; v < s.verts.size(); ++v)
    if ((s.verts.flags[v] & kBoundary) && (s.verts.rest[v] - from).norm() < 0.004)
      near.push_back({(s.verts.rest[v] - from).norm(), v});
  std::sort(near.begin(), near.end());
  const double area = total_rest_area(s.tris);
  for (const auto& [dist, v] : near) {
    const int32_t id = static_cast<int32_t>(s.tears.size());
    const Vec2 start = s.verts.rest[v];
    const CutResult res = cut_tear_segment(v, to, previous, id, RemeshParams{}, s);
    if (!res.cut) continue;
    EXPECT_EQ(check_mesh_invariants(s, area), "") << "cut from (" << from.x() << ", " << from.y() << ")";
    Tear t;
    t.id = id;
    t.start_uv = start;
    t.tips = {start, res.end};
    t.reached_boundary = res.reached_boundary;
    s.tears.push_back(t);
    if (!res.reached_boundary) s.tips.push_back(Tip{res.tip_vertex, id, (res.end - start).normalized()});
    return res;
  }
  return CutResult{};
}

}  // namespace

TEST(Hostile, SheetCutIntoManySmallPieces) {
  // A 0.1 m square (no notch), four fingers; before frame 0 it is cut into a 4 x 4 grid of pieces by
  // straight tears right across, then pulled and dropped.
  const char* square = "[[0,0],[0.1,0],[0.1,0.1],[0,0.1]]";
  const std::string fingers = R"([
    {"name": "A", "at": [0.01, 0.01], "keys": [[0, [0.01, 0.01, 0]], [1, [-0.05, -0.05, 0.1]]]},
    {"name": "B", "at": [0.09, 0.09], "keys": [[0, [0.09, 0.09, 0]], [1, [0.15, 0.15, 0.1]]]},
    {"name": "C", "at": [0.09, 0.01]}, {"name": "D", "at": [0.01, 0.09], "release": 0.5}])";
  const Scenario sc = parse_scenario(scene("many-pieces", fingers, 40, "", square, 400), "pieces.json");
  auto between = [](Simulation& sim, int frame) {
    if (frame != 0) return;
    Sheet& s = mutable_sheet(sim);
    for (double x : {0.025, 0.05, 0.075}) {
      const CutResult r = cut_tear(s, Vec2(x, 0), Vec2(x, 0.2));
      EXPECT_TRUE(r.cut && r.reached_boundary) << x;
    }
    // Across every strip: from each strip's left lip to its right one.
    for (double y : {0.025, 0.05, 0.075})
      for (double x0 : {0.0, 0.025, 0.05, 0.075}) {
        const CutResult r = cut_tear(s, Vec2(x0, y), Vec2(x0 + 0.0375, y));
        EXPECT_TRUE(r.cut) << x0 << ", " << y;
      }
    sim.notify_topology_changed();
    EXPECT_GE(sim.sheet().topo.piece_count, 12);
  };
  const Outcome a = run(sc, 40, 1, between);
  const Outcome b = run(sc, 40, 2, between);
  EXPECT_EQ(a.hash, b.hash);
  EXPECT_TRUE(a.error.empty()) << a.error;
  EXPECT_GE(b.pieces, 12);
}

TEST(Hostile, ManyFingersTearManyPieces) {
  // A comb: four notches on the top edge, fingers pulling every tooth apart from its neighbours.
  const char* comb =
      "[[0,0],[0.1,0],[0.1,0.1],[0.082,0.1],[0.08,0.085],[0.078,0.1],[0.062,0.1],[0.06,0.085],[0.058,0.1],"
      "[0.042,0.1],[0.04,0.085],[0.038,0.1],[0.022,0.1],[0.02,0.085],[0.018,0.1],[0,0.1]]";
  std::ostringstream f;
  f << "[";
  for (int i = 0; i < 5; ++i) {
    const double u = 0.01 + 0.02 * i, dir = (i % 2 ? 1 : -1);
    f << (i ? "," : "") << R"({"name": "T)" << i << R"(", "at": [)" << u << R"(, 0.092], "keys": [[0, [)" << u
      << ", 0.092, 0]], [1.5, [" << u + 0.01 * (i - 2) << ", 0.092, " << 0.08 * dir << "]]]}";
  }
  f << R"(, {"name": "Base", "at": [0.05, 0.01]}])";
  const Outcome o = run_both(scene("comb", f.str(), 60, "", comb, 400), 60);
  EXPECT_TRUE(o.error.empty()) << o.error;
}

TEST(Hostile, TearsMeetAtGrazingAngles) {
  // Before frame 0: a tear from the left edge nearly along the bottom edge (0.5° off it), one that
  // approaches the first tear's lip at 1°, one running into a corner, then fingers pull everything.
  const char* square = "[[0,0],[0.1,0],[0.1,0.1],[0,0.1]]";
  const std::string fingers = R"([
    {"name": "A", "at": [0.02, 0.06], "keys": [[0, [0.02, 0.06, 0]], [1, [0.0, 0.06, 0.05]]]},
    {"name": "B", "at": [0.08, 0.06], "keys": [[0, [0.08, 0.06, 0]], [1, [0.1, 0.06, -0.05]]]},
    {"name": "C", "at": [0.05, 0.005], "keys": [[0, [0.05, 0.005, 0]], [1, [0.05, -0.03, 0]]]}])";
  const Scenario sc = parse_scenario(scene("grazing", fingers, 45, "", square, 400), "grazing.json");
  auto between = [](Simulation& sim, int frame) {
    if (frame != 0) return;
    Sheet& s = mutable_sheet(sim);
    const double g = 0.5 * std::numbers::pi / 180;
    const CutResult r1 = cut_tear(s, Vec2(0, 0.01), Vec2(0, 0.01) + 0.08 * Vec2(std::cos(g), -std::sin(g)));
    EXPECT_TRUE(r1.cut);
    const double h = std::numbers::pi / 180;
    const CutResult r2 = cut_tear(s, Vec2(0.1, 0.02), Vec2(0.1, 0.02) + 0.2 * Vec2(-std::cos(h), -std::sin(h)));
    EXPECT_TRUE(r2.cut);
    const CutResult r3 = cut_tear(s, Vec2(0.05, 0.1), Vec2(0.1, 0.0499));  // towards the corner region
    EXPECT_TRUE(r3.cut);
    // Along the boundary itself (refused: nothing changes) and from a tip straight back into its lips.
    const std::string before = hash_sheet(s);
    const CutResult r4 = cut_tear(s, Vec2(0.0, 0.05), Vec2(0.0, 0.09));
    EXPECT_FALSE(r4.cut);
    EXPECT_EQ(hash_sheet(s), before);
    sim.notify_topology_changed();
  };
  const Outcome a = run(sc, 45, 1, between);
  const Outcome b = run(sc, 45, 2, between);
  EXPECT_EQ(a.hash, b.hash);
  EXPECT_TRUE(a.error.empty()) << a.error;
}

TEST(Hostile, TearRunsIntoAnotherAtGrazingAnglePulled) {
  // Two notches facing each other on the left and right edges, offset by 2 mm, pulled so both tears run
  // towards each other and pass almost head-on.
  const char* outline = "[[0,0],[0.1,0],[0.1,0.049],[0.088,0.05],[0.1,0.051],[0.1,0.1],[0,0.1],[0,0.053],[0.012,0.052],[0,0.051]]";
  const std::string fingers = R"([
    {"name": "A", "at": [0.05, 0.08], "keys": [[0, [0.05, 0.08, 0]], [1.5, [0.05, 0.11, 0.08]]]},
    {"name": "B", "at": [0.05, 0.02], "keys": [[0, [0.05, 0.02, 0]], [1.5, [0.05, -0.01, -0.08]]]}])";
  run_both(scene("head-on", fingers, 60, "", outline, 400), 60);
}

// Issue 27: a run whose solver refuses (nearly) every substep is not a result: status "error" with the reason
// (before: "ok" while 30 of 30 substeps were refused and the sheet never moved). Inputs that do this are
// refused at validation, so the material is changed behind its back, as a tool with mutable_sheet() could.
TEST(Hostile, SolverRefusingEverySubstepIsAnError) {
  Simulation sim(parse_scenario(scene("stuck", pair_apart(0.03, 0.1, 1.5), 3), "stuck.json"));
  mutable_sheet(sim).material.young = 1e200;  // the implicit solver cannot factorise this
  for (int f = 0; f < 3; ++f) sim.step();
  sim.flush();
  ASSERT_GE(solver_stats(sim).failures, 3 * 10);
  nlohmann::ordered_json doc;
  std::string error;
  EXPECT_FALSE(build_result_json(sim, doc, &error));
  EXPECT_EQ(doc["status"], "error");
  ASSERT_TRUE(doc.contains("error"));
  EXPECT_EQ(doc["error"], error);
  EXPECT_EQ(error.rfind("the solver refused ", 0), 0u) << error;
  EXPECT_NE(error.find(" of the run's 30 substeps"), std::string::npos) << error;
  EXPECT_EQ(std::next(doc.begin())->get<std::string>(), "error");  // "status" right after "scenario"
  EXPECT_EQ(std::next(doc.begin(), 2).key(), "error");
  EXPECT_EQ(error.rfind(solver_failure(sim), 0), 0u) << error;  // the solver's reason first
  // A healthy run of the same scene: no reason, status "ok".
  Simulation good(parse_scenario(scene("moving", pair_apart(0.03, 0.1, 1.5), 3), "moving.json"));
  for (int f = 0; f < 3; ++f) good.step();
  good.flush();
  EXPECT_EQ(solver_failure(good), "");
  EXPECT_TRUE(build_result_json(good, doc, &error));
  EXPECT_EQ(doc["status"], "ok");
  EXPECT_FALSE(doc.contains("error"));
}

// Issue 27, item 14: far from the origin rounding tore a falling sheet apart. A vertex beyond
// ±kMaxSheetPosition stops the simulation: no further frame runs, and the result is an error that says
// which vertex left, when and where.
TEST(Hostile, SheetFlungBeyondThePositionBoundStops) {
  const char* let_go = R"([{"name": "a", "at": [0.02, 0.02], "keys": [[0, [0.02, 0.02, 0]]], "release": 0.001}])";
  Simulation sim(parse_scenario(scene("flung", let_go, 5), "flung.json"));
  sim.step();
  EXPECT_EQ(sim.stop_reason(), "");
  for (Vec3& v : mutable_sheet(sim).verts.v) v = Vec3(0, 0, 1e8);  // 3.3e6 m in a frame of 1/30 s
  sim.step();
  ASSERT_EQ(sim.frame(), 2);
  const std::string reason = sim.stop_reason();
  EXPECT_NE(reason.find(" left the +-1e+06 m bound of positions at frame 2 (at ("), std::string::npos) << reason;
  const std::string hash = sim.state_hash();
  sim.step();
  EXPECT_EQ(sim.frame(), 2);
  EXPECT_EQ(sim.state_hash(), hash);
  EXPECT_EQ(solver_failure(sim), reason);
  nlohmann::ordered_json doc;
  std::string error;
  EXPECT_FALSE(build_result_json(sim, doc, &error));
  EXPECT_EQ(doc["status"], "error");
  EXPECT_EQ(error, reason);
}

// Issue 27: the interactive API refuses a finger that does not exist and a target that is not a place
// (before: NaN, inf and 1e300 were keyed; 999 threw "vector::_M_range_check", −1 showed 18446744073709551615).
TEST(Hostile, MoveFingerRefusesBadFingersAndTargets) {
  Simulation sim(parse_scenario(scene("api", pair_apart(0.03, 0.1, 1.5), 3), "api.json"));
  const auto message = [&](const std::function<void()>& call) -> std::string {
    try {
      call();
    } catch (const InputError& e) {
      return e.what();
    } catch (const std::exception& e) {
      return std::string("wrong exception type: ") + e.what();
    }
    return "no error";
  };
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(message([&] { sim.move_finger(999, Vec3(0, 0, 0)); }),
            "move_finger: no finger 999 (the sheet has fingers 0 to 1)");
  EXPECT_EQ(message([&] { sim.move_finger(-1, Vec3(0, 0, 0)); }),
            "move_finger: no finger -1 (the sheet has fingers 0 to 1)");
  EXPECT_EQ(message([&] { sim.release_finger(2); }), "release_finger: no finger 2 (the sheet has fingers 0 to 1)");
  for (const Vec3& bad : {Vec3(nan, 0, 0), Vec3(0, inf, 0), Vec3(0, 0, -inf), Vec3(1e300, 0, 0), Vec3(0, -1001, 0)}) {
    const std::string m = message([&] { sim.move_finger(1, bad); });
    EXPECT_EQ(m.rfind("move_finger: finger 1 (B): target ", 0), 0u) << m;
  }
  EXPECT_NE(message([&] { sim.move_finger(0, Vec3(nan, 0, 0)); }).find("not a finite point"), std::string::npos);
  EXPECT_NE(message([&] { sim.move_finger(0, Vec3(1e300, 0, 0)); }).find("at most 1000 m"), std::string::npos);
  const std::string before = sim.state_hash();
  sim.step();  // the refused targets left no key behind
  std::string where;
  EXPECT_TRUE(all_finite(sim.sheet(), where)) << where;
  for (const Finger& f : sim.sheet().fingers)
    for (const FingerKey& k : f.keys) EXPECT_TRUE(k.position.allFinite() && k.position.norm() < 1) << f.name;
  EXPECT_NE(sim.state_hash(), before);
  EXPECT_EQ(message([&] { sim.move_finger(0, Vec3(0.035, 0.09, 0.02)); }), "no error");
  EXPECT_EQ(message([&] { sim.move_finger(1, Vec3(0, -1000, 0)); }), "no error");  // far, but a place
}

// Issue 27, item 3: a simulation of 100 000 threads crashed on destruction inside its task arena. The
// library refuses a thread count outside 1 to kMaxThreads with an InputError naming it, and builds at
// the cap; a batch does the same.
TEST(Hostile, ThreadCountsOutsideTheCapAreRefused) {
  const Scenario s = parse_scenario(scene("threads", pair_apart(0.03, 0.1, 1.5), 2), "threads.json");
  for (const int32_t bad : {0, -3, kMaxThreads + 1, 100000}) {
    EngineOptions o;
    o.threads = bad;
    try {
      Simulation sim(s, o);
      ADD_FAILURE() << bad << " threads accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("threads: must be 1 to 1024, got " + std::to_string(bad)), std::string::npos)
          << e.what();
    }
    BatchOptions b;
    b.sheets = 1;
    b.threads = bad;
    EXPECT_THROW(run_batch(s, b), InputError) << bad;
  }
  EngineOptions at_cap;
  at_cap.threads = kMaxThreads;
  Simulation sim(s, at_cap);
  sim.step();
  EXPECT_EQ(sim.threads(), kMaxThreads);
}
