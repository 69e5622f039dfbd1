// Scenario files (docs/scenario-format.md, version 1): strict loading. Unknown keys, wrong types, wrong array
// lengths, non-finite or non-positive physical constants, degenerate outlines and fingers outside the sheet
// are InputError with the file and the JSON path of the problem.
#pragma once

#include "../components/errors.hpp"
#include "../components/obstacles.hpp"
#include "../components/sheet.hpp"

#include <array>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace pt {

struct DetailSettings {
  std::array<int32_t, 2> texture{0, 0};  // [width, height] px; 0,0: ~0.1 mm per pixel over the bounding box
  // σ of eq. 7's G_i, m. 1 mm, chosen by looking (docs/fig19.md): at 0.1 mm the detailed path stays
  // within a pixel of the coarse segment and the torn edge reads as cut with scissors.
  double sigma = 1e-3;
  double omega = 0.5;
};

// How a tear tip picks its direction, and how its cuts snap (the "tearing" object; optional).
struct TearingSettings {
  // "tension_rays" (default): the load points' shortest paths in the torn pattern and their reactions
  // (docs/tearing.md); "fan" (alias "bisector"): eq. 4–6 on the tip's fan, the paper's literal rule;
  // "material_force": the J-integral's direction of largest energy release, Er from the fan.
  std::string direction = "tension_rays";
  double radius = 0.04;                // m, the J-integral's domain ("material_force", and the rays' fallback)
  std::optional<double> snap;          // remeshing's snap fraction of an edge; unset: the direction's default
  // The tearing step's constants a user may tune (docs/tearing.md; their defaults are the tearing step's
  // own, systems/tearing/tearing_step.hpp and tension_ray_decision.hpp):
  double shielding_radius = 0.01;  // m: no new tear starts this close to an active tip (crack shielding)
  double max_turn_deg = 75;        // a tip's largest turn per step (a tear does not fold back into its lips)
  double start_wrap = 0.003;       // m: an inward corner starts only this close to the path between two loads
  double start_length = 0.01;      // m: the edge length whose tension starts a tear at a convex point
  double edge_radius = 0.005;      // m: the disc over which that tension is read
  double bearing_length = 0.005;   // m: a load's bearing is read this far along its path (smaller notch
                                   // features do not steer)
  double opening_floor = 0.1;      // the least weight of a pull opening a tip in the sheet's plane (mode I)
  // A tension-ray tip follows O'Keefe's hyperbola, on which an offset from the snap persists and grows:
  // 0.03 of an edge keeps a symmetric pull within 0.3% of its mediator (0.06: up to 8%) without slivers.
  double snap_fraction() const {
    if (snap) return *snap;
    if (direction == "bisector" || direction == "fan") return 0.25;
    return direction == "material_force" ? 0.06 : 0.03;
  }
};

// "sim": {"self_contact": {...}}: the sheet and its pieces do not pass through themselves or each other
// (systems/physics/self_contact.hpp, docs/scenario-format.md "Self-contact"). Off unless the key is given.
struct SelfContactSettings {
  bool on = false;
  double gap = 3e-4;     // m: pairs closer than this repel (three thicknesses of office paper)
  double friction = 0.3; // Coulomb μ, paper on paper
};

struct SimSettings {
  double fps = 30;
  int32_t substeps = 10;
  int32_t frames = 90;
  Vec3 gravity = Vec3(0, 0, -9.81);
  int32_t iterations = 2;  // read and checked; no effect (they were the refused projective solver's)
  std::string solver = "implicit";  // "implicit" (linearly implicit corotated); "projective" is refused
  // The relaxation after a propagation (paper Fig. 4, step 4), so that the lips move apart before the next
  // propagation: "substep" runs one more implicit substep right after the cut, then treats the frame's
  // other candidates; "next_frame" leaves it to the next frame's physics and treats no other candidate
  // this frame (at most one propagation per frame, no extra substep: the big sheet's choice, where a
  // substep is a whole factorisation); "patch" runs the extra substep on the vertices within
  // relaxation_radius of the tear's path only, the rest of the sheet held (systems/physics/local_relaxation.hpp),
  // then treats the other candidates as "substep" does.
  std::string relaxation = "substep";
  double relaxation_radius = 0.03;  // m, pattern: the patch of "patch"
  SelfContactSettings self_contact;
  // Step splitting (systems/physics/integrate_implicit.hpp): a substep that stretched a triangle past the
  // strain limit by more than split_strain_jump beyond its start is redone as two halves, at most
  // step_splits halvings deep (0: off).
  int32_t step_splits = 3;
  double split_strain_jump = 0.0025;
};

struct FingerSpec {
  std::string name;
  Vec2 at = Vec2::Zero();
  std::vector<FingerKey> keys;
  std::string interpolation = "linear";  // how the keys are joined: "linear" or "smooth" (key_interpolation_from_name)
  double attach = 0;         // s: put on the sheet then (0: from the start, a mesh vertex is placed at `at`)
  double release = 1e300;    // s: let go then
  double grip = 15;          // N: the largest force the pinch holds before the paper slides through it
  double pad = 0;            // m: radius of the patch the pinch holds (0: a point; systems/physics/fingers.hpp)
};

struct HandSpec {
  std::string name;
  std::vector<std::string> fingers;
  std::vector<HandKey> keys;
  std::string interpolation = "linear";  // as for a finger
};

struct Scenario {
  std::string name;
  std::string path;             // file it came from ("" when built in code)
  std::string description;      // free text ("description" key; JSON has no comments)
  std::vector<Vec2> outline;    // counter-clockwise, meters (from "outline" or "preset")
  std::string preset;           // "" when an outline was given
  int32_t triangles = 400;
  uint64_t mesh_seed = 0;
  double mesh_rotation_deg = 0;
  bool hand_lines = false;      // the line between a hand's consecutive fingers meshed as edges
  Material material;
  DetailSettings detail;
  SimSettings sim;
  TearingSettings tearing;
  std::vector<FingerSpec> fingers;
  std::vector<HandSpec> hands;
  // Planes and boxes the sheet cannot pass (docs/scenario-format.md, "Obstacles"); plane normals unit.
  std::vector<Obstacle> obstacles;
};

// Parse and validate. Throws InputError.
Scenario load_scenario(const std::string& path);
// The file with `settings` ("sim.relaxation=patch", "material.fracture_c=3e4", as `papertear --set`) written
// into its JSON before it is read: the same checks, and an error says it came with the settings.
Scenario load_scenario(const std::string& path, const std::vector<std::string>& settings);
Scenario parse_scenario(const std::string& json_text, const std::string& path_for_messages);
// parse_scenario for a scenario built in code (the Python module's Scenario): the same reading and checks,
// except that it may have no fingers, as validate_scenario allows (a sheet falling freely, or fingers
// attached while it runs).
Scenario parse_scenario_in_code(const std::string& json_text, const std::string& path_for_messages);

// Checks that do not depend on JSON (outline simple and CCW, fingers inside, constants positive and
// finite, sizes sane). Throws InputError naming `s.path`. Called by parse_scenario; call it on scenarios
// built in code.
void validate_scenario(const Scenario& s);

// The most triangles a scenario may ask for: the largest sheet's estimated peak memory (below), for the
// mesh's +20% and two sheets at once (a batch's default threads), stays well inside a 24 GB machine.
inline constexpr int32_t kMaxSheetTriangles = 500'000;
// Estimated peak resident bytes of a simulation of a sheet of `triangles` triangles (docs/memory.md: peak
// RSS of one frame of scenarios/demo.json at 50 000 to 200 000 triangles; the factor's fill grows like
// n log n).
double estimated_sheet_bytes(int64_t triangles);

// Every position of the sheet stays within ±kMaxSheetPosition m on each axis (docs/scenario-format.md):
// beyond it doubles resolve the sheet's strains too coarsely (at 4.5e16 m a free fall tore a sheet into
// 139 pieces). Validation refuses scenarios whose keys or free fall can carry the sheet beyond it, and a
// simulation stops when a vertex leaves it anyway (Simulation::stop_reason).
inline constexpr double kMaxSheetPosition = 1e6;

}  // namespace pt
