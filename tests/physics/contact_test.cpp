// Obstacles (systems/physics/contact.hpp) in the default integrator: after every substep no vertex is
// below a plane or inside a box; a sheet resting on a table keeps its energy; friction follows Coulomb's
// law on a slope (stays at μ above tan θ, slides with the analytic acceleration below); a scenario's
// pieces come to rest on the floor, bit-identically at 1 and 2 threads; every validation error of the
// "obstacles" key is one line naming the file and the JSON path.
#include "engine/scenario.hpp"
#include "engine/simulation.hpp"
#include "engine/simulation_internals.hpp"
#include "systems/mesh/self_intersection.hpp"
#include "systems/physics/bending_forces.hpp"
#include "systems/physics/integrate_implicit.hpp"
#include "systems/physics/membrane_forces.hpp"
#include "systems/physics/contact.hpp"
#include "tests/test_meshes.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

using namespace pt;

namespace {

Obstacle plane(const Vec3& point, const Vec3& normal, double friction) {
  Obstacle o;
  o.kind = Obstacle::Kind::Plane;
  o.point = point;
  o.normal = normal.normalized();
  o.friction = friction;
  return o;
}

Obstacle box(const Vec3& lo, const Vec3& hi, double friction) {
  Obstacle o;
  o.kind = Obstacle::Kind::Box;
  o.min = lo;
  o.max = hi;
  o.friction = friction;
  return o;
}

double lowest_distance(const Sheet& s, const Obstacle& o) {
  double lowest = INFINITY;
  for (const Vec3& x : s.verts.x) lowest = std::min(lowest, obstacle_distance(o, x));
  return lowest;
}

double max_speed(const Sheet& s) {
  double v = 0;
  for (const Vec3& x : s.verts.v) v = std::max(v, x.norm());
  return v;
}

Vec3 centroid(const Sheet& s) {
  Vec3 c = Vec3::Zero();
  for (const Vec3& x : s.verts.x) c += x;
  return c / s.verts.size();
}

// Kinetic + membrane + bending + gravity's potential.
double total_energy(const Sheet& s, const Vec3& gravity) {
  std::vector<BendingStencil> stencils;
  build_bending_stencils(s.verts.rest, s.topo.hinges, bending_stiffness(s.material), stencils);
  double e = membrane_energy(s.verts.x, s.tris.tri, s.tris.rest_inv, s.tris.rest_area, membrane_params(s.material)) +
             bending_energy(s.verts.x, stencils);
  for (int32_t i = 0; i < s.verts.size(); ++i)
    e += s.verts.mass[i] * (0.5 * s.verts.v[i].squaredNorm() - gravity.dot(s.verts.x[i]));
  return e;
}

ImplicitParams params_with(std::vector<Obstacle> obstacles, const Sheet& s) {
  ImplicitParams p;
  p.obstacles = std::move(obstacles);
  p.contact_offset = 0.5 * s.material.thickness;
  return p;
}

}  // namespace

TEST(Contact, ATiltedDropNeverEndsASubstepBelowTheFloorAndComesToRest) {
  Sheet s = test::grid_sheet(0.2, 0.2, 10, 10, 0.2, 5);
  for (int32_t v = 0; v < s.verts.size(); ++v) s.verts.x[v].z() = 0.02 + 0.1 * s.verts.rest[v].x();  // one edge first
  const Obstacle floor = plane(Vec3::Zero(), Vec3(0, 0, 1), 0.5);
  const ImplicitParams p = params_with({floor}, s);
  ImplicitSolverPtr solver;
  for (int step = 0; step < 900; ++step) {  // 3 s
    ASSERT_TRUE(implicit_substep(p, {}, {}, solver, s));
    ASSERT_GE(lowest_distance(s, floor), 0) << "substep " << step;
  }
  EXPECT_GT(implicit_solver_stats(*solver).contacts, 0);
  EXPECT_LT(max_speed(s), 1e-3) << "at rest on the floor";
  EXPECT_LT(lowest_distance(s, floor), 1e-3) << "on it, not floating";
}

TEST(Contact, ASheetDrapedOverABoxNeverHasAVertexInsideIt) {
  Sheet s = test::grid_sheet(0.2, 0.2, 12, 12, 0.2, 7);
  for (Vec3& x : s.verts.x) x.z() = 0.03;
  // A narrow box under the sheet's middle, on a floor: the sheet drapes over it and its sides reach the floor.
  const Obstacle block = box(Vec3(0.08, -0.1, -0.05), Vec3(0.12, 0.3, 0.01), 0.3);
  const Obstacle floor = plane(Vec3(0, 0, -0.05), Vec3(0, 0, 1), 0.5);
  const ImplicitParams p = params_with({block, floor}, s);
  ImplicitSolverPtr solver;
  for (int step = 0; step < 600; ++step) {
    ASSERT_TRUE(implicit_substep(p, {}, {}, solver, s));
    ASSERT_GE(lowest_distance(s, block), 0) << "substep " << step;
    ASSERT_GE(lowest_distance(s, floor), 0) << "substep " << step;
  }
  double top = -INFINITY;
  for (const Vec3& x : s.verts.x) top = std::max(top, x.z());
  EXPECT_GT(top, 0.01) << "held up by the box";
  EXPECT_LT(top, 0.015) << "bulging a little beside its edges, not flung";
  EXPECT_LT(max_speed(s), 1e-3) << "at rest";
}

TEST(Contact, ASheetRestingOnATableKeepsItsEnergy) {
  Sheet s = test::grid_sheet(0.2, 0.2, 10, 10, 0.2, 3);
  const Obstacle table = plane(Vec3::Zero(), Vec3(0, 0, 1), 0.5);
  for (Vec3& x : s.verts.x) x.z() = 0.5 * s.material.thickness;
  const ImplicitParams p = params_with({table}, s);
  ImplicitSolverPtr solver;
  const double start = total_energy(s, p.gravity);
  for (int step = 0; step < 300; ++step) {
    ASSERT_TRUE(implicit_substep(p, {}, {}, solver, s));
    ASSERT_LE(total_energy(s, p.gravity), start + 1e-12) << "substep " << step;
    ASSERT_GE(lowest_distance(s, table), 0);
  }
  EXPECT_LT(max_speed(s), 1e-9);
}

namespace {
// A sheet lying on a slope of angle θ (normal (−sin θ, 0, cos θ)), friction μ, for `seconds`: how far its
// centroid moved.
double slope_slide(double theta, double mu, double seconds) {
  Sheet s = test::grid_sheet(0.1, 0.1, 6, 6, 0.2, 2);
  const Vec3 n(-std::sin(theta), 0, std::cos(theta)), along(std::cos(theta), 0, std::sin(theta));
  for (int32_t v = 0; v < s.verts.size(); ++v)
    s.verts.x[v] = s.verts.rest[v].x() * along + Vec3(0, s.verts.rest[v].y(), 0) + 0.5 * s.material.thickness * n;
  const Obstacle slope = plane(Vec3::Zero(), n, mu);
  const ImplicitParams p = params_with({slope}, s);
  ImplicitSolverPtr solver;
  const Vec3 start = centroid(s);
  const int steps = static_cast<int>(std::lround(seconds / p.dt));
  for (int step = 0; step < steps; ++step) {
    EXPECT_TRUE(implicit_substep(p, {}, {}, solver, s));
    EXPECT_GE(lowest_distance(s, slope), 0);
  }
  return (centroid(s) - start).norm();
}

// Rigid sliding down a slope θ with friction μ and the mass damping α: dv/dt = g (sin θ − μ cos θ) − α v,
// so from rest s(t) = (a/α) (t − (1 − e^{−αt})/α).
double rigid_slide(double theta, double mu, double t) {
  const double alpha = ImplicitParams{}.mass_damping, a = 9.81 * (std::sin(theta) - mu * std::cos(theta));
  return a / alpha * (t - (1 - std::exp(-alpha * t)) / alpha);
}
}  // namespace

TEST(Contact, FrictionAboveTheSlopesTangentHoldsTheSheet) {
  const double theta = 20 * M_PI / 180;
  EXPECT_LT(slope_slide(theta, 1.2 * std::tan(theta), 1.0), 1e-9);
}

TEST(Contact, FrictionBelowTheSlopesTangentLetsItSlideAsCoulombSays) {
  const double theta = 20 * M_PI / 180, mu = 0.8 * std::tan(theta), t = 1.0;
  const double expected = rigid_slide(theta, mu, t);
  const double moved = slope_slide(theta, mu, t);
  EXPECT_NEAR(moved, expected, 0.02 * expected) << "expected " << expected;
}

namespace {
constexpr double kTableSheet = 0.1;  // m, the side of the square sheet on the table

// The vertex at the middle of the sheet's left (x = 0) or right edge.
int32_t edge_middle(const Sheet& s, bool left) {
  for (int32_t v = 0; v < s.verts.size(); ++v)
    if (std::abs(s.verts.rest[v].y() - 0.5 * kTableSheet) < 1e-9 &&
        std::abs(s.verts.rest[v].x() - (left ? 0 : kTableSheet)) < 1e-9)
      return v;
  return -1;
}

// A sheet lying on a table at height `table_z` (friction μ) moved along +x at `speed` for 0.6 s by the
// middle of its left edge (a push) or its right edge (a drag), then held still for 0.3 s.
struct TableMove {
  double steady = 0;   // N: the mean force the sheet puts on the held vertex over the motion's last 0.2 s
  double stopped = 0;  // N: the largest after the stop
};
TableMove move_on_table(const Sheet& start, double mu, bool push, double speed, double table_z) {
  Sheet s = start;
  const ImplicitParams p = params_with({plane(Vec3(0, 0, table_z), Vec3(0, 0, 1), mu)}, s);
  const int32_t held = edge_middle(s, push);
  ImplicitSolverPtr solver;
  const int moving = static_cast<int>(std::lround(0.6 / p.dt)), averaged = static_cast<int>(std::lround(0.2 / p.dt));
  const int steps = moving + static_cast<int>(std::lround(0.3 / p.dt));
  TableMove m;
  for (int step = 0; step < steps; ++step) {
    const Vec3 target = s.verts.x[held] + Vec3(step < moving ? speed * p.dt : 0, 0, 0);
    EXPECT_TRUE(implicit_substep(p, {held}, {target}, solver, s));
    const double force = s.verts.force[held].norm();  // of the state the step started from
    if (step >= moving - averaged && step < moving) m.steady += force / averaged;
    if (step > moving) m.stopped = std::max(m.stopped, force);
  }
  return m;
}
}  // namespace

// Coulomb's cap holds for the whole sheet, not only for a vertex alone: a finger dragging or pushing a sheet
// that lies on a table at a steady speed feels the friction of the weight it moves, μ M g, and the mass
// damping α M v; when it stops, at most that and the sheet's momentum spent in one substep. With the table
// at the finger's height (a scenario's table through z = 0: the finger holds its vertex half a thickness
// below the surface the rest lies on, pressing the sheet) the force is a few times that, and before the
// rounds that release overloaded stickers it was 55 N (drag) and 130 N (push): the stickers beyond the
// first rings held what the finger pushed.
TEST(Contact, ASheetDraggedOrPushedAlongATableFeelsCoulombsFrictionOfItsWeight) {
  const double mu = 0.4, speed = 0.05, dt = ImplicitParams{}.dt;
  const Sheet s = test::grid_sheet(kTableSheet, kTableSheet, 16, 16, 0.2, 4);
  double mass = 0;
  for (const double m : s.verts.mass) mass += m;
  for (const bool push : {false, true}) {
    const double moved = mass - s.verts.mass[edge_middle(s, push)];  // the held vertex is not dragged
    const double expected = moved * (mu * 9.81 + ImplicitParams{}.mass_damping * speed);
    const TableMove rest = move_on_table(s, mu, push, speed, -0.5 * s.material.thickness);
    EXPECT_NEAR(rest.steady, expected, 0.05 * expected) << (push ? "push" : "drag");
    EXPECT_LT(rest.stopped, expected + moved * speed / dt) << (push ? "push" : "drag");
    const TableMove pressed = move_on_table(s, mu, push, speed, 0);
    EXPECT_LT(std::max(pressed.steady, pressed.stopped), 20 * expected) << (push ? "push" : "drag");
  }
  EXPECT_LT(move_on_table(s, 0, false, speed, -0.5 * s.material.thickness).steady, 0.05 * mass * 9.81)
      << "frictionless: the mass damping only";
}

namespace {
// A 4 cm square sheet lying at the self-contact gap on a 10 cm one held still, both in one Sheet (apart in
// the pattern), under gravity tilted by θ along x (a slope of angle θ) with friction μ between them in the
// implicit solve, for `seconds`: how far the top sheet's centroid moved. The pairs are found before every
// substep as the engine finds them (Simulation's find_self_pairs).
double layer_slide(double theta, double mu, double seconds) {
  const Sheet bottom = test::grid_sheet(0.1, 0.1, 6, 6), top = test::grid_sheet(0.04, 0.04, 3, 3);
  const int32_t nb = bottom.verts.size(), nt = top.verts.size();
  SelfContactParams contact;
  Sheet s;
  s.verts.resize(nb + nt);
  for (int32_t i = 0; i < nb; ++i) {
    s.verts.rest[i] = bottom.verts.rest[i];
    s.verts.x[i] = bottom.verts.x[i];
  }
  for (int32_t i = 0; i < nt; ++i) {
    s.verts.rest[nb + i] = top.verts.rest[i] + Vec2(0.2, 0);
    s.verts.x[nb + i] = Vec3(0.01 + top.verts.rest[i].x(), 0.03 + top.verts.rest[i].y(), contact.gap);
  }
  std::vector<Tri> tris = bottom.tris.tri;
  for (const Tri& t : top.tris.tri) tris.push_back({t[0] + nb, t[1] + nb, t[2] + nb});
  s.tris.resize(static_cast<int32_t>(tris.size()));
  s.tris.tri = tris;
  refresh_after_topology_change(s);

  std::vector<int32_t> held(nb);
  std::vector<Vec3> target(nb);
  for (int32_t i = 0; i < nb; ++i) held[i] = i, target[i] = s.verts.x[i];
  std::vector<ProximityPair> pairs;
  ImplicitParams p;
  p.gravity = 9.81 * Vec3(std::sin(theta), 0, -std::cos(theta));
  p.self_pairs = &pairs;
  p.self_gap = contact.gap;
  p.self_friction = mu;
  SelfContactBroadPhasePtr broad;
  ImplicitSolverPtr solver;
  auto top_centroid = [&] {
    Vec3 c = Vec3::Zero();
    for (int32_t i = nb; i < nb + nt; ++i) c += s.verts.x[i];
    return (c / nt).eval();
  };
  const Vec3 start = top_centroid();
  std::vector<Vec3> predicted;
  const int steps = static_cast<int>(std::lround(seconds / p.dt));
  for (int step = 0; step < steps; ++step) {
    predicted = s.verts.x;
    for (int32_t i = nb; i < nb + nt; ++i) predicted[i] += p.dt * s.verts.v[i];
    self_contact_proximities(contact, s.tris.tri, s.verts.rest, s.verts.x, predicted, broad, pairs);
    EXPECT_TRUE(implicit_substep(p, held, target, solver, s));
    for (int32_t i = nb; i < nb + nt; ++i) EXPECT_GT(s.verts.x[i].z(), 0.5 * contact.gap) << "step " << step;
  }
  return (top_centroid() - start).norm();
}
}  // namespace

// Friction between layers is Coulomb's in the solve, as on an obstacle, relative to the layer below: a sheet
// on a sheet held on a slope stays when μ is above tan θ and otherwise slides as the slope test above says.
// (Before, the pairs were frictionless in the solve and any slope let the top sheet slide.)
TEST(Contact, FrictionBetweenLayersHoldsOrLetsSlideAsCoulombSays) {
  const double theta = 20 * M_PI / 180, t = 0.25;
  EXPECT_LT(layer_slide(theta, 1.2 * std::tan(theta), t), 1e-6);
  const double mu = 0.8 * std::tan(theta), expected = rigid_slide(theta, mu, t);
  EXPECT_NEAR(layer_slide(theta, mu, t), expected, 0.03 * expected) << "expected " << expected;
}

TEST(Contact, WithoutObstaclesTheStepIsUnchanged) {
  Sheet a = test::grid_sheet(0.2, 0.2, 8, 8, 0.2, 3), b = a;
  ImplicitParams plain;
  ImplicitParams far = params_with({plane(Vec3(0, 0, -100), Vec3(0, 0, 1), 0.5)}, a);
  ImplicitSolverPtr sa, sb;
  for (int step = 0; step < 30; ++step) {
    ASSERT_TRUE(implicit_substep(plain, {}, {}, sa, a));
    ASSERT_TRUE(implicit_substep(far, {}, {}, sb, b));
  }
  EXPECT_EQ(hash_sheet(a), hash_sheet(b)) << "an obstacle never touched changes nothing";
}

// ---- scenarios ------------------------------------------------------------------------------------------

TEST(ContactScenario, PiecesOnTheFloorComeToRestAboveItAtOneAndTwoThreads) {
  const Scenario sc = load_scenario(std::string(PT_SOURCE_DIR) + "/scenarios/pieces-on-floor.json");
  ASSERT_FALSE(sc.obstacles.empty());
  std::string hashes[2];
  for (int threads : {1, 2}) {
    EngineOptions o;
    o.threads = threads;
    Simulation sim(sc, o);
    for (int f = 0; f < sc.sim.frames; ++f) {
      sim.step();
      for (const Obstacle& ob : sc.obstacles)
        if (ob.kind == Obstacle::Kind::Plane) {
          ASSERT_GE(lowest_distance(sim.sheet(), ob), 0) << "frame " << f;
        }
    }
    hashes[threads - 1] = sim.state_hash();
    if (threads == 2) {
      EXPECT_LT(max_speed(sim.sheet()), 0.02) << "at rest";
      EXPECT_GE(sim.sheet().topo.piece_count, 2) << "torn in two";
    }
  }
  EXPECT_EQ(hashes[0], hashes[1]);
}

// The same pieces on other meshes land where they fall and stay: on meshes 3 and 6 a landing vertex's
// friction, taken from the motion of the solve before the last, pushed it instead of holding it, and the
// membrane flung the piece metres along the floor (27-31 m/s) with triangles stretched 12-49% (friction_pushes,
// systems/physics/integrate_implicit.cpp). A piece falling 35 cm lands at 2.6 m/s; once one has landed no
// vertex moves faster than 3 m/s, and every vertex ends within 30 cm of where the sheet hung (a piece
// ~10 cm tall topples as it lands: on mesh 6 its far edge ends 17.8 cm out, 25.3 cm with split steps).
TEST(ContactScenario, PiecesLandWhereTheyFallOnOtherMeshes) {
  for (const uint64_t seed : {3, 6}) {
    Scenario sc = load_scenario(std::string(PT_SOURCE_DIR) + "/scenarios/pieces-on-floor.json");
    sc.mesh_seed = seed;
    sc.mesh_rotation_deg = 17.0 * double(seed);
    EngineOptions o;
    o.threads = 1;
    Simulation sim(sc, o);
    double floor_z = 0;
    for (const Obstacle& ob : sc.obstacles) floor_z = ob.point.z();
    bool landed = false;
    double fastest_after_landing = 0;
    for (int f = 0; f < sc.sim.frames; ++f) {
      sim.step();
      if (landed) fastest_after_landing = std::max(fastest_after_landing, max_speed(sim.sheet()));
      for (const Vec3& x : sim.sheet().verts.x) landed = landed || x.z() < floor_z + 0.001;
    }
    ASSERT_TRUE(landed) << "seed " << seed;
    EXPECT_LT(fastest_after_landing, 3.0) << "seed " << seed;
    const Sheet& s = sim.sheet();
    EXPECT_LT(max_speed(s), 0.02) << "seed " << seed << ": at rest";
    for (const Vec3& x : s.verts.x)
      ASSERT_LT(std::hypot(x.x() - 0.0525, x.y() - 0.074), 0.30) << "seed " << seed << ": " << x.transpose();
    EXPECT_LT(sim.max_strain_beyond_tips(), 0.05) << "seed " << seed;
  }
}

// An A5 sheet on a table folded in half (scenarios/fold-half.json): its top half lands on its bottom half.
// With sim.self_contact no two triangles that share no vertex intersect after any substep (the exact count,
// systems/mesh/self_intersection.hpp), no vertex is below the table, nothing tears or slips, and the sheet
// comes to rest without gaining energy; without it the top half passes into the bottom one. Measured
// 2026-12-05: without, 2 intersecting pairs from frame 60 and 3.1 N on the top fingers as they land; with,
// none and 1.0 N.
TEST(ContactScenario, AFoldedSheetLandsOnItselfWithoutPassingThrough) {
  Scenario sc = load_scenario(std::string(PT_SOURCE_DIR) + "/scenarios/fold-half.json");
  ASSERT_TRUE(sc.sim.self_contact.on);
  ASSERT_EQ(sc.obstacles.size(), 1u);
  const Obstacle table = sc.obstacles[0];
  EngineOptions o;
  o.threads = 2;
  for (const bool on : {true, false}) {
    sc.sim.self_contact.on = on;
    Simulation sim(sc, o);
    int64_t substeps = 0, intersecting = 0;
    double lowest = INFINITY;
    set_substep_observer(sim, [&](const Sheet& s) {
      substeps += 1;
      intersecting = std::max(intersecting, count_self_intersections(s.verts.x, s.tris.tri).intersecting);
      lowest = std::min(lowest, lowest_distance(s, table));
    });
    // The hands stop at 2 s (frame 60): from then on nothing does work on the sheet, and contact must not
    // add energy (kinetic, membrane, bending and gravity's, 4.4 mJ). This measure leaves out the pinches'
    // stiffer compression, and at rest it jitters by up to 1e-8 J from frame to frame with or without
    // contact: a frame may gain no more than ten times that, and the end holds no more than the start.
    std::vector<double> energy;
    for (int f = 0; f < sc.sim.frames; ++f) {
      sim.step();
      if (f >= 62) energy.push_back(total_energy(sim.sheet(), sc.sim.gravity));
    }
    const Sheet& s = sim.sheet();
    if (on) {
      for (size_t k = 1; k < energy.size(); ++k) EXPECT_LE(energy[k], energy[k - 1] + 1e-7) << "frame " << 63 + k;
      EXPECT_LT(energy.back(), energy.front());
    }
    if (!on) {
      EXPECT_GT(intersecting, 0) << "without self-contact the top half passes into the bottom one";
      continue;
    }
    EXPECT_EQ(substeps, int64_t{sc.sim.frames} * sc.sim.substeps);
    EXPECT_EQ(intersecting, 0) << "after some substep";
    EXPECT_GE(lowest, 0) << "a vertex below the table";
    EXPECT_TRUE(s.tears.empty());
    for (const Finger& f : s.fingers) {
      EXPECT_EQ(f.slips, 0) << f.name;
      EXPECT_LT(f.max_force, 2.0) << f.name;
    }
    EXPECT_LT(max_speed(s), 0.02) << "at rest";
    EXPECT_LT(sim.max_strain(), 0.02);
  }
}

// An A5 sheet bent into a U by two hands and pulled apart with a twist (u-twist-pull.json) with self-contact
// tears as without, stretches less than 5% and leaves no pair unresolved after the pass. Without the
// rounds that add the pairs a fast layer's last solve brings near (integrate_implicit.cpp,
// kSelfPairRounds) it tore twice where it tore once without, and stretched 7.2%. (Since substeps that jump
// past the strain limit are split, neither tears: the one tear came from such a substep's stretch,
// docs/physics.md, "Step splitting".) Its triangles intersect far less than without self-contact (checked
// after every substep), but not never (docs/physics.md, "Self-contact", known gaps).
TEST(ContactScenario, ATwistedPullWithSelfContactTearsAsWithout) {
  Scenario sc = load_scenario(std::string(PT_SOURCE_DIR) + "/scenarios/u-twist-pull.json");
  EngineOptions o;
  o.threads = 2;
  int64_t intersecting[2] = {0, 0};
  size_t tears[2] = {0, 0};
  for (const bool on : {false, true}) {
    sc.sim.self_contact.on = on;
    Simulation sim(sc, o);
    set_substep_observer(sim, [&](const Sheet& s) {
      intersecting[on] = std::max(intersecting[on], count_self_intersections(s.verts.x, s.tris.tri).intersecting);
    });
    for (int f = 0; f < sc.sim.frames; ++f) sim.step();
    tears[on] = sim.sheet().tears.size();
    if (!on) continue;
    EXPECT_EQ(self_contact_stats(sim)->unresolved, 0);
    EXPECT_LT(sim.max_strain(), 0.05);
  }
  EXPECT_EQ(tears[1], tears[0]);
  EXPECT_LE(tears[1], 1u);
  EXPECT_LT(4 * intersecting[1], intersecting[0]) << "with self-contact " << intersecting[1] << ", without "
                                                  << intersecting[0];
}

// A notched A6 sheet torn on a table (table-tear.json) with self-contact tears as without: one tear, one
// piece, no slip, the same strain to 0.5%, nothing below the table and no pair left unresolved. Its tip
// advanced by fractions of a millimetre near the end and left triangles of 0.5 mm whose vertices lay within
// the gap of triangles two rings away; kept a gap apart in the solve, they stretched 41% in a substep and
// the sheet blew up to 10^6 m in frame 100 (pairs are now between pattern strangers only).
TEST(ContactScenario, ASheetTornOnATableWithSelfContactTearsAsWithout) {
  Scenario sc = load_scenario(std::string(PT_SOURCE_DIR) + "/scenarios/table-tear.json");
  ASSERT_EQ(sc.obstacles.size(), 1u);
  EngineOptions o;
  o.threads = 2;
  double strain[2] = {0, 0};
  for (const bool on : {false, true}) {
    sc.sim.self_contact.on = on;
    Simulation sim(sc, o);
    double lowest = INFINITY;
    set_substep_observer(sim, [&](const Sheet& s) { lowest = std::min(lowest, lowest_distance(s, sc.obstacles[0])); });
    for (int f = 0; f < sc.sim.frames; ++f) {
      sim.step();
      // A sheet that blew up takes minutes a frame in its collision passes: stop there.
      ASSERT_LT(max_speed(sim.sheet()), 10.0) << "frame " << f << ", self-contact " << on;
    }
    const Sheet& s = sim.sheet();
    EXPECT_EQ(s.tears.size(), 1u) << "self-contact " << on;
    EXPECT_EQ(s.topo.piece_count, 1) << "self-contact " << on;
    for (const Finger& f : s.fingers) EXPECT_EQ(f.slips, 0) << f.name << ", self-contact " << on;
    EXPECT_GE(lowest, 0) << "a vertex below the table, self-contact " << on;
    strain[on] = sim.max_strain();
    if (on) EXPECT_EQ(self_contact_stats(sim)->unresolved, 0);
  }
  EXPECT_NEAR(strain[1], strain[0], 0.005);
}

// fig18-crumple on 1 000 triangles with self-contact does not blow up. Its linear steps let part of the
// sheet snap through at 1.5 m/s in frame 75 (a substep stretched one triangle 27%); the pairs the solve then
// kept apart dragged vertices out of their layers, and by frame 115 the strain was 432 with 9 187
// collisions, a frame taking 12 s (sim.step_splits 0). With substeps split where they jump past the strain
// limit (docs/physics.md, "Step splitting") it ends below 5% strain, without shredding, with no pair left
// unresolved and no two triangles intersecting after any substep.
TEST(ContactScenario, ACrumpledSheetOfAThousandTrianglesWithSelfContactStaysWhole) {
  Scenario sc = load_scenario(std::string(PT_SOURCE_DIR) + "/scenarios/fig18-crumple.json", {"sheet.triangles=1000"});
  sc.sim.self_contact.on = true;
  EngineOptions o;
  o.threads = 2;
  Simulation sim(sc, o);
  int64_t intersecting = 0;
  set_substep_observer(sim, [&](const Sheet& s) {
    intersecting = std::max(intersecting, count_self_intersections(s.verts.x, s.tris.tri).intersecting);
  });
  for (int f = 0; f < sc.sim.frames; ++f) {
    sim.step();
    // A sheet that blew up takes seconds a frame in its collision passes: stop there.
    ASSERT_LT(max_speed(sim.sheet()), 10.0) << "frame " << f;
  }
  EXPECT_GT(sim.sheet().tris.size(), 900);
  EXPECT_LT(sim.max_strain(), 0.05);
  EXPECT_LE(sim.sheet().tears.size(), 3u);
  EXPECT_LE(sim.sheet().topo.piece_count, 2);
  EXPECT_EQ(self_contact_stats(sim)->unresolved, 0);
  EXPECT_EQ(intersecting, 0);
}

// ---- validation -----------------------------------------------------------------------------------------

namespace {
std::string refusal(const std::string& obstacles, const std::string& sim = "") {
  const std::string text = R"({"sheet": {"preset": "A5", "triangles": 60}, "fingers": [{"name": "a", "at": [0.05, 0.05]}],)" +
                           (sim.empty() ? std::string() : "\"sim\": " + sim + ",") + "\"obstacles\": " + obstacles + "}";
  try {
    parse_scenario(text, "obst.json");
  } catch (const InputError& e) {
    return e.what();
  }
  return "(accepted)";
}
void expect_refused(const std::string& obstacles, const std::string& path, const std::string& words,
                    const std::string& sim = "") {
  const std::string message = refusal(obstacles, sim);
  EXPECT_EQ(message.rfind("obst.json: " + path + ":", 0), 0u) << message;
  EXPECT_NE(message.find(words), std::string::npos) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
}
}  // namespace

TEST(ContactValidation, GoodObstaclesAreAccepted) {
  EXPECT_EQ(refusal(R"([{"type": "plane", "point": [0, 0, -0.1], "normal": [0, 0, 2], "friction": 0.4},
                        {"type": "box", "min": [0, 0, -0.2], "max": [0.1, 0.1, -0.1]}])"),
            "(accepted)");
}

TEST(ContactValidation, EachBadValueIsOneLineWithItsPath) {
  expect_refused(R"({"type": "plane"})", "obstacles", "expected an array");
  expect_refused(R"([{"point": [0, 0, 0], "normal": [0, 0, 1]}])", "obstacles[0]", "missing type");
  expect_refused(R"([{"type": "cone"}])", "obstacles[0].type", "unknown obstacle type");
  expect_refused(R"([{"type": "plane", "normal": [0, 0, 1]}])", "obstacles[0]", "missing point");
  expect_refused(R"([{"type": "plane", "point": [0, 0, 0]}])", "obstacles[0]", "missing normal");
  expect_refused(R"([{"type": "plane", "point": [0, 0, -1], "normal": [0, 0, 0]}])", "obstacles[0].normal", "non-zero");
  expect_refused(R"([{"type": "plane", "point": [0, 0, -1], "normal": [0, 1]}])", "obstacles[0].normal", "3 numbers");
  expect_refused(R"([{"type": "plane", "point": [0, 0, -1], "normal": [0, 0, 1], "min": [0, 0, 0]}])",
                 "obstacles[0].min", "unknown key");
  expect_refused(R"([{"type": "plane", "point": [0, 0, -1], "normal": [0, 0, 1], "friction": -0.1}])",
                 "obstacles[0].friction", "must not be negative");
  expect_refused(R"([{"type": "plane", "point": [0, 0, -1], "normal": [0, 0, 1], "friction": 1e9}])",
                 "obstacles[0].friction", "absurd friction");
  expect_refused(R"([{"type": "plane", "point": [0, 0, 1e9], "normal": [0, 0, 1]}])", "obstacles[0].point[2]",
                 "absurd coordinate");
  expect_refused(R"([{"type": "box", "min": [0, 0, -1], "max": [1, 0, -0.5]}])", "obstacles[0].max[1]", "must exceed min[1]");
  expect_refused(R"([{"type": "box", "min": [0, 0, -1], "max": [1, 1, -2]}])", "obstacles[0].max[2]", "must exceed min[2]");
  expect_refused(R"([{"type": "box", "max": [1, 1, 1]}])", "obstacles[0]", "missing min");
  expect_refused(R"([{"type": "box", "min": [0, 0, -1], "max": [1, 1, -0.5], "normal": [0, 0, 1]}])",
                 "obstacles[0].normal", "unknown key");
}

TEST(ContactValidation, ASheetThatStartsInsideAnObstacleIsRefused) {
  // The sheet lies in z = 0 over the A5 rectangle [0, 0.148] x [0, 0.21].
  expect_refused(R"([{"type": "plane", "point": [0, 0, 0.01], "normal": [0, 0, 1]}])", "obstacles[0]", "starts below");
  expect_refused(R"([{"type": "plane", "point": [0.1, 0, 0], "normal": [-1, 0, 0.1]}])", "obstacles[0]", "starts below");
  expect_refused(R"([{"type": "box", "min": [0.05, 0.05, -0.01], "max": [0.06, 0.06, 0.01]}])", "obstacles[0]",
                 "starts inside this box");  // wholly under the sheet
  expect_refused(R"([{"type": "box", "min": [-1, 0.1, -0.01], "max": [1, 0.11, 0.01]}])", "obstacles[0]",
                 "starts inside this box");  // a bar across it, no corner inside
  EXPECT_EQ(refusal(R"([{"type": "box", "min": [0.2, 0, -0.01], "max": [0.3, 0.1, 0.01]}])"), "(accepted)")
      << "beside the sheet";
  EXPECT_EQ(refusal(R"([{"type": "box", "min": [0, 0, -0.01], "max": [0.1, 0.1, 0]}])"), "(accepted)")
      << "the sheet lying on its top";
}
