// Scenario files (docs/scenario-format.md): strict loading. Parsing checks shape and types (with the JSON
// path of every value); validate_scenario checks values and geometry on the struct, so scenarios built in
// code get the same checks and the same messages.
#include "engine/scenario.hpp"

#include "systems/mesh/meshing.hpp"
#include "systems/physics/fingers.hpp"
#include "systems/tearing/tearing_step.hpp"

#include <nlohmann/json.hpp>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <initializer_list>
#include <limits>
#include <set>
#include <string_view>

namespace pt {
namespace {

using json = nlohmann::json;

// Limits that keep a typo (1e12 triangles, 1e9 px textures) from turning into an hour of swapping.
constexpr int64_t kMinTriangles = 2;
constexpr int64_t kMaxTriangles = 2'000'000;
constexpr int64_t kMaxFrames = 10'000'000;
constexpr int64_t kMaxSubsteps = 10'000;
constexpr int64_t kMaxStepSplits = 8;  // a substep halved 8 times is 1/256 of it: past that the step is not the problem
constexpr int64_t kMaxIterations = 1'000;
constexpr int64_t kMaxTexture = 16'384;
constexpr double kMaxFps = 100'000;
constexpr double kMaxCoordinate = 1'000;   // m: outline and finger targets
constexpr double kMaxGravity = 10'000;     // m/s²
constexpr double kMaxKeyTime = 1e7;        // s
constexpr double kMaxGrip = 1e4;           // N
constexpr double kMaxPad = 0.05;           // m: a clamp as wide as a hand
constexpr int32_t kMaxObstacles = 1'000;    // each is a pass over the vertices per substep
constexpr double kMaxFriction = 100;        // Coulomb μ (rubber on rubber is ~1–2)
constexpr double kMaxSelfContactGap = 0.01; // m: a gap wider than a mesh's edges would push neighbours apart
constexpr int64_t kMaxFileBytes = 64ll << 20;
// What a sheet can physically be (README, "Scenario format"). Beyond these the implicit solver refuses
// every substep (the sheet stands still) or the state overflows: no result, so the input is refused.
constexpr double kMinThickness = 1e-6, kMaxThickness = 0.01;  // m: cling film to thick board
constexpr double kMinDensity = 1, kMaxDensity = 25'000;        // kg/m³: aerogel to osmium
constexpr double kMinYoung = 1e3, kMaxYoung = 1e12;            // Pa: a soft gel to diamond
constexpr double kMaxBendingScale = 1e4;                       // of paper's E e³ / 12(1 − ν²)
constexpr double kMinFps = 1;                                  // frames/s: a frame lasts at most a second
// J/m²: below 10 a sheet tears under its own weight (a trouser start at Ef·e/2 ≈ 5e-4 N; tissue paper is
// ~2 500, office paper 2.5e4), and at 0 it shattered into thousands of pieces.
constexpr double kMinFractureC = 10, kMaxFractureC = 1e9;
constexpr int kMaxDepth = 32;

std::string file_label(const std::string& path) { return path.empty() ? "<scenario>" : path; }

// Messages must stay one line whatever the file holds (binary garbage is echoed by the JSON parser).
std::string one_line(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (const unsigned char c : s) {
    if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else if (c == '\n' || c == '\r' || c == '\t') {
      out += ' ';
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
    }
  }
  return out;
}

std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

std::string fmt_uv(const Vec2& p) {
  char buf[64];  // one snprintf: GCC 12 warns falsely (-Wrestrict) on "(" + std::string&& once this is inlined
  std::snprintf(buf, sizeof buf, "(%.6g, %.6g)", p.x(), p.y());
  return buf;
}

[[noreturn]] void fail(const std::string& file, const std::string& json_path, const std::string& problem) {
  if (json_path.empty()) throw InputError(one_line(file_label(file) + ": " + problem));
  throw InputError(one_line(file_label(file) + ": " + json_path + ": " + problem));
}

std::string child(const std::string& path, const char* key) { return path.empty() ? key : path + "." + key; }
std::string child(const std::string& path, const std::string& key) { return child(path, key.c_str()); }
std::string child(const std::string& path, size_t index) { return path + "[" + std::to_string(index) + "]"; }

const char* type_name(const json& j) {
  if (j.is_boolean()) return "a boolean";
  if (j.is_number()) return "a number";
  if (j.is_string()) return "a string";
  if (j.is_array()) return "an array";
  if (j.is_object()) return "an object";
  return "null";
}

// ---- checks shared by parsing (before narrowing to int32) and validate_scenario ----

void check_int(const std::string& file, const std::string& path, double v, int64_t lo, int64_t hi) {
  if (v > static_cast<double>(hi))
    fail(file, path, "absurd size " + fmt(v) + " (at most " + std::to_string(hi) + ")");
  if (v < static_cast<double>(lo)) fail(file, path, "must be at least " + std::to_string(lo) + ", got " + fmt(v));
}

void check_finite(const std::string& file, const std::string& path, double v) {
  if (!std::isfinite(v)) fail(file, path, "expected a finite number");
}

void check_positive(const std::string& file, const std::string& path, double v) {
  check_finite(file, path, v);
  if (!(v > 0)) fail(file, path, "must be positive, got " + fmt(v));
}

void check_non_negative(const std::string& file, const std::string& path, double v) {
  check_finite(file, path, v);
  if (v < 0) fail(file, path, "must not be negative, got " + fmt(v));
}

// [lo, hi] or [lo, hi) when hi_open.
void check_range(const std::string& file, const std::string& path, double v, double lo, double hi, bool hi_open) {
  check_finite(file, path, v);
  if (v < lo || v > hi || (hi_open && v == hi))
    fail(file, path, "must be in [" + fmt(lo) + ", " + fmt(hi) + (hi_open ? ")" : "]") + ", got " + fmt(v));
}

// A physical constant within what a sheet can be; `unit` is shown after the range ("" for factors).
void check_plausible(const std::string& file, const std::string& path, double v, double lo, double hi,
                     const std::string& unit) {
  check_finite(file, path, v);
  if (v < lo || v > hi)
    fail(file, path, "outside the plausible range [" + fmt(lo) + ", " + fmt(hi) + "]" + (unit.empty() ? "" : " " + unit) +
                         ", got " + fmt(v));
}

void check_vec(const std::string& file, const std::string& path, const double* v, int n, double max_abs) {
  for (int i = 0; i < n; ++i) {
    check_finite(file, child(path, size_t(i)), v[i]);
    if (std::abs(v[i]) > max_abs)
      fail(file, child(path, size_t(i)), "absurd coordinate " + fmt(v[i]) + " (at most " + fmt(max_abs) + " m)");
  }
}

// ---- typed readers: shape and type, with the JSON path in every message ----

struct Reader {
  std::string file;

  void expect_object(const json& j, const std::string& path) const {
    if (!j.is_object()) fail(file, path, std::string("expected an object, got ") + type_name(j));
  }

  void expect_array(const json& j, const std::string& path) const {
    if (!j.is_array()) fail(file, path, std::string("expected an array, got ") + type_name(j));
  }

  void check_keys(const json& j, const std::string& path, std::initializer_list<const char*> allowed) const {
    for (auto it = j.begin(); it != j.end(); ++it) {
      bool known = false;
      for (const char* a : allowed) known = known || it.key() == a;
      if (known) continue;
      std::string list;
      for (const char* a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
      fail(file, child(path, it.key()), "unknown key (expected one of: " + list + ")");
    }
  }

  double number(const json& j, const std::string& path) const {
    if (!j.is_number()) fail(file, path, std::string("expected a number, got ") + type_name(j));
    const double v = j.get<double>();
    check_finite(file, path, v);
    return v;
  }

  // Integral numbers only (1e12 is written as a float in JSON, so integral floats are accepted and
  // then meet the range check, which says "absurd size" rather than "expected an integer").
  int64_t integer(const json& j, const std::string& path, int64_t lo, int64_t hi) const {
    if (!j.is_number()) fail(file, path, std::string("expected an integer, got ") + type_name(j));
    if (j.is_number_unsigned()) {
      const uint64_t u = j.get<uint64_t>();
      check_int(file, path, static_cast<double>(u), lo, hi);
      return static_cast<int64_t>(u);
    }
    if (j.is_number_integer()) {
      const int64_t v = j.get<int64_t>();
      check_int(file, path, static_cast<double>(v), lo, hi);
      return v;
    }
    const double v = j.get<double>();
    check_finite(file, path, v);
    if (v != std::floor(v)) fail(file, path, "expected an integer, got " + fmt(v));
    check_int(file, path, v, lo, hi);
    return static_cast<int64_t>(v);
  }

  uint64_t seed(const json& j, const std::string& path) const {
    if (j.is_number_unsigned()) return j.get<uint64_t>();
    return static_cast<uint64_t>(integer(j, path, 0, std::numeric_limits<int64_t>::max()));
  }

  std::string string(const json& j, const std::string& path) const {
    if (!j.is_string()) fail(file, path, std::string("expected a string, got ") + type_name(j));
    return j.get<std::string>();
  }

  template <int N>
  Eigen::Matrix<double, N, 1> vec(const json& j, const std::string& path) const {
    if (!j.is_array() || j.size() != N) {
      const std::string got = j.is_array() ? "an array of " + std::to_string(j.size()) : type_name(j);
      fail(file, path, "expected an array of " + std::to_string(N) + " numbers, got " + got);
    }
    Eigen::Matrix<double, N, 1> v;
    for (int i = 0; i < N; ++i) v[i] = number(j[i], child(path, size_t(i)));
    return v;
  }

  // A key is [t, value]: exactly two entries.
  const json& key_pair(const json& j, const std::string& path) const {
    if (!j.is_array() || j.size() != 2) {
      const std::string got = j.is_array() ? "an array of " + std::to_string(j.size()) : type_name(j);
      fail(file, path, "expected a key [t, value], got " + got);
    }
    return j;
  }
};

// ---- the sections of the file ----

void read_sheet(const Reader& r, const json& j, Scenario& s) {
  const std::string path = "sheet";
  r.expect_object(j, path);
  r.check_keys(j, path, {"outline", "preset", "triangles", "mesh_seed", "mesh_rotation_deg", "hand_lines"});
  const bool has_outline = j.contains("outline");
  const bool has_preset = j.contains("preset");
  if (has_outline && has_preset) fail(r.file, path, "give either outline or preset, not both");
  if (!has_outline && !has_preset) fail(r.file, path, "missing outline (or preset)");
  if (has_outline) {
    const std::string p = child(path, "outline");
    const json& o = j["outline"];
    r.expect_array(o, p);
    if (o.size() > 100'000) fail(r.file, p, "absurd size: " + std::to_string(o.size()) + " vertices (at most 100000)");
    s.outline.clear();
    s.outline.reserve(o.size());
    for (size_t i = 0; i < o.size(); ++i) s.outline.push_back(r.vec<2>(o[i], child(p, i)));
    s.preset.clear();
  } else {
    const std::string p = child(path, "preset");
    s.preset = r.string(j["preset"], p);
    try {
      s.outline = preset_outline(s.preset);
    } catch (const GeometryError& e) {
      fail(r.file, p, e.what());
    }
  }
  if (j.contains("triangles"))
    s.triangles = static_cast<int32_t>(r.integer(j["triangles"], child(path, "triangles"), kMinTriangles, kMaxTriangles));
  if (j.contains("mesh_seed")) s.mesh_seed = r.seed(j["mesh_seed"], child(path, "mesh_seed"));
  if (j.contains("mesh_rotation_deg"))
    s.mesh_rotation_deg = r.number(j["mesh_rotation_deg"], child(path, "mesh_rotation_deg"));
  if (j.contains("hand_lines")) {
    const json& h = j["hand_lines"];
    if (!h.is_boolean()) fail(r.file, child(path, "hand_lines"), std::string("expected a boolean, got ") + type_name(h));
    s.hand_lines = h.get<bool>();
  }
}

void read_material(const Reader& r, const json& j, Material& m) {
  const std::string path = "material";
  r.expect_object(j, path);
  r.check_keys(j, path, {"thickness", "density", "young", "poisson", "bending_scale", "tip_damage", "fiber_seed",
                         "fracture_c", "speed", "max_step", "damping", "fiber_scale", "fiber_floor", "min_step",
                         "membrane_scale", "strain_limit", "compression_scale", "compression_limit"});
  const std::pair<const char*, double*> numbers[] = {
      {"thickness", &m.thickness},   {"density", &m.density},       {"young", &m.young},
      {"poisson", &m.poisson},       {"bending_scale", &m.bending_scale}, {"tip_damage", &m.tip_damage},
      {"fracture_c", &m.fracture_c}, {"speed", &m.speed},           {"max_step", &m.max_step},
      {"damping", &m.damping},       {"fiber_scale", &m.fiber_scale}, {"fiber_floor", &m.fiber_floor},
      {"min_step", &m.min_step},     {"membrane_scale", &m.membrane_scale}, {"strain_limit", &m.strain_limit},
      {"compression_scale", &m.compression_scale}, {"compression_limit", &m.compression_limit}};
  for (const auto& [key, dst] : numbers)
    if (j.contains(key)) *dst = r.number(j[key], child(path, key));
  if (j.contains("fiber_seed")) m.fiber_seed = r.seed(j["fiber_seed"], child(path, "fiber_seed"));
}

void read_detail(const Reader& r, const json& j, DetailSettings& d) {
  const std::string path = "detail";
  r.expect_object(j, path);
  r.check_keys(j, path, {"texture", "sigma", "omega"});
  if (j.contains("texture")) {
    const std::string p = child(path, "texture");
    const json& t = j["texture"];
    if (!t.is_array() || t.size() != 2) {
      const std::string got = t.is_array() ? "an array of " + std::to_string(t.size()) : type_name(t);
      fail(r.file, p, "expected an array of 2 integers [width, height], got " + got);
    }
    for (size_t i = 0; i < 2; ++i)
      d.texture[i] = static_cast<int32_t>(r.integer(t[i], child(p, i), 0, kMaxTexture));
  }
  if (j.contains("sigma")) d.sigma = r.number(j["sigma"], child(path, "sigma"));
  if (j.contains("omega")) d.omega = r.number(j["omega"], child(path, "omega"));
}

void read_sim(const Reader& r, const json& j, SimSettings& sim) {
  const std::string path = "sim";
  r.expect_object(j, path);
  r.check_keys(j, path,
               {"fps", "substeps", "frames", "gravity", "iterations", "solver", "relaxation", "relaxation_radius",
                "self_contact", "step_splits", "split_strain_jump"});
  if (j.contains("fps")) sim.fps = r.number(j["fps"], child(path, "fps"));
  if (j.contains("substeps"))
    sim.substeps = static_cast<int32_t>(r.integer(j["substeps"], child(path, "substeps"), 1, kMaxSubsteps));
  if (j.contains("frames"))
    sim.frames = static_cast<int32_t>(r.integer(j["frames"], child(path, "frames"), 1, kMaxFrames));
  if (j.contains("gravity")) sim.gravity = r.vec<3>(j["gravity"], child(path, "gravity"));
  if (j.contains("iterations"))
    sim.iterations = static_cast<int32_t>(r.integer(j["iterations"], child(path, "iterations"), 1, kMaxIterations));
  if (j.contains("solver")) sim.solver = r.string(j["solver"], child(path, "solver"));
  if (j.contains("relaxation")) sim.relaxation = r.string(j["relaxation"], child(path, "relaxation"));
  if (j.contains("relaxation_radius"))
    sim.relaxation_radius = r.number(j["relaxation_radius"], child(path, "relaxation_radius"));
  if (j.contains("step_splits"))
    sim.step_splits = static_cast<int32_t>(r.integer(j["step_splits"], child(path, "step_splits"), 0, kMaxStepSplits));
  if (j.contains("split_strain_jump"))
    sim.split_strain_jump = r.number(j["split_strain_jump"], child(path, "split_strain_jump"));
  if (j.contains("self_contact")) {
    // true (the defaults), false (off), or {"gap", "friction"} (on).
    const std::string p = child(path, "self_contact");
    const json& c = j["self_contact"];
    if (c.is_boolean()) {
      sim.self_contact.on = c.get<bool>();
    } else {
      if (!c.is_object())
        fail(r.file, p, std::string("expected an object {\"gap\", \"friction\"} or a boolean, got ") + type_name(c));
      r.check_keys(c, p, {"gap", "friction"});
      sim.self_contact.on = true;
      if (c.contains("gap")) sim.self_contact.gap = r.number(c["gap"], child(p, "gap"));
      if (c.contains("friction")) sim.self_contact.friction = r.number(c["friction"], child(p, "friction"));
    }
  }
}

void read_tearing(const Reader& r, const json& j, TearingSettings& t) {
  const std::string path = "tearing";
  r.expect_object(j, path);
  r.check_keys(j, path, {"direction", "radius", "snap", "shielding_radius", "max_turn_deg", "start_wrap",
                         "start_length", "edge_radius", "bearing_length", "opening_floor"});
  if (j.contains("direction")) t.direction = r.string(j["direction"], child(path, "direction"));
  if (j.contains("radius")) t.radius = r.number(j["radius"], child(path, "radius"));
  if (j.contains("snap")) t.snap = r.number(j["snap"], child(path, "snap"));
  for (const auto& [key, value] : {std::pair<const char*, double*>{"shielding_radius", &t.shielding_radius},
                                   {"max_turn_deg", &t.max_turn_deg},
                                   {"start_wrap", &t.start_wrap},
                                   {"start_length", &t.start_length},
                                   {"edge_radius", &t.edge_radius},
                                   {"bearing_length", &t.bearing_length},
                                   {"opening_floor", &t.opening_floor}})
    if (j.contains(key)) *value = r.number(j[key], child(path, key));
}

void read_fingers(const Reader& r, const json& j, std::vector<FingerSpec>& fingers) {
  const std::string path = "fingers";
  r.expect_array(j, path);
  fingers.clear();
  for (size_t i = 0; i < j.size(); ++i) {
    const std::string p = child(path, i);
    const json& f = j[i];
    r.expect_object(f, p);
    r.check_keys(f, p, {"name", "at", "keys", "interpolation", "attach", "release", "grip", "pad"});
    FingerSpec spec;
    if (!f.contains("name")) fail(r.file, p, "missing name");
    spec.name = r.string(f["name"], child(p, "name"));
    if (!f.contains("at")) fail(r.file, p, "missing at (the pattern point [u, v] the finger holds)");
    spec.at = r.vec<2>(f["at"], child(p, "at"));
    if (f.contains("keys")) {
      const std::string kp = child(p, "keys");
      r.expect_array(f["keys"], kp);
      for (size_t k = 0; k < f["keys"].size(); ++k) {
        const std::string kk = child(kp, k);
        const json& key = r.key_pair(f["keys"][k], kk);
        FingerKey fk;
        fk.t = r.number(key[0], child(kk, size_t(0)));
        fk.position = r.vec<3>(key[1], child(kk, size_t(1)));
        spec.keys.push_back(fk);
      }
    }
    if (f.contains("interpolation")) spec.interpolation = r.string(f["interpolation"], child(p, "interpolation"));
    // A finger put on the sheet (or let go) during a session: a vertex is inserted at `at` then.
    if (f.contains("attach")) spec.attach = r.number(f["attach"], child(p, "attach"));
    if (f.contains("release")) spec.release = r.number(f["release"], child(p, "release"));
    if (f.contains("grip")) spec.grip = r.number(f["grip"], child(p, "grip"));
    if (f.contains("pad")) spec.pad = r.number(f["pad"], child(p, "pad"));
    fingers.push_back(std::move(spec));
  }
}

void read_hands(const Reader& r, const json& j, std::vector<HandSpec>& hands) {
  const std::string path = "hands";
  r.expect_array(j, path);
  hands.clear();
  for (size_t i = 0; i < j.size(); ++i) {
    const std::string p = child(path, i);
    const json& h = j[i];
    r.expect_object(h, p);
    r.check_keys(h, p, {"name", "fingers", "keys", "interpolation"});
    HandSpec spec;
    if (!h.contains("name")) fail(r.file, p, "missing name");
    spec.name = r.string(h["name"], child(p, "name"));
    if (!h.contains("fingers")) fail(r.file, p, "missing fingers (names of the fingers the hand moves)");
    const std::string fp = child(p, "fingers");
    r.expect_array(h["fingers"], fp);
    for (size_t k = 0; k < h["fingers"].size(); ++k) spec.fingers.push_back(r.string(h["fingers"][k], child(fp, k)));
    if (h.contains("keys")) {
      const std::string kp = child(p, "keys");
      r.expect_array(h["keys"], kp);
      for (size_t k = 0; k < h["keys"].size(); ++k) {
        const std::string kk = child(kp, k);
        const json& key = r.key_pair(h["keys"][k], kk);
        HandKey hk;
        hk.t = r.number(key[0], child(kk, size_t(0)));
        const std::string mp = child(kk, size_t(1));
        const json& m = key[1];
        r.expect_object(m, mp);
        r.check_keys(m, mp, {"translate", "rotate_deg", "axis"});
        if (m.contains("translate")) hk.translate = r.vec<3>(m["translate"], child(mp, "translate"));
        if (m.contains("rotate_deg")) hk.rotate_deg = r.number(m["rotate_deg"], child(mp, "rotate_deg"));
        if (m.contains("axis")) hk.axis = r.vec<3>(m["axis"], child(mp, "axis"));
        spec.keys.push_back(hk);
      }
    }
    if (h.contains("interpolation")) spec.interpolation = r.string(h["interpolation"], child(p, "interpolation"));
    hands.push_back(std::move(spec));
  }
}

void read_obstacles(const Reader& r, const json& j, std::vector<Obstacle>& obstacles) {
  const std::string path = "obstacles";
  r.expect_array(j, path);
  if (j.size() > static_cast<size_t>(kMaxObstacles))
    fail(r.file, path, "absurd size: " + std::to_string(j.size()) + " obstacles (at most " + std::to_string(kMaxObstacles) + ")");
  for (size_t i = 0; i < j.size(); ++i) {
    const std::string p = child(path, i);
    const json& o = j[i];
    r.expect_object(o, p);
    if (!o.contains("type")) fail(r.file, p, "missing type (\"plane\" or \"box\")");
    const std::string type = r.string(o["type"], child(p, "type"));
    Obstacle ob;
    if (type == "plane") {
      r.check_keys(o, p, {"type", "point", "normal", "friction"});
      if (!o.contains("point")) fail(r.file, p, "missing point (a point [x, y, z] on the plane)");
      if (!o.contains("normal")) fail(r.file, p, "missing normal (the side [x, y, z] the sheet stays on)");
      ob.kind = Obstacle::Kind::Plane;
      ob.point = r.vec<3>(o["point"], child(p, "point"));
      ob.normal = r.vec<3>(o["normal"], child(p, "normal"));
    } else if (type == "box") {
      r.check_keys(o, p, {"type", "min", "max", "friction"});
      if (!o.contains("min")) fail(r.file, p, "missing min (the corner [x, y, z] of smallest coordinates)");
      if (!o.contains("max")) fail(r.file, p, "missing max (the corner [x, y, z] of largest coordinates)");
      ob.kind = Obstacle::Kind::Box;
      ob.min = r.vec<3>(o["min"], child(p, "min"));
      ob.max = r.vec<3>(o["max"], child(p, "max"));
    } else {
      fail(r.file, child(p, "type"), "unknown obstacle type \"" + type + "\" (plane or box)");
    }
    if (o.contains("friction")) ob.friction = r.number(o["friction"], child(p, "friction"));
    obstacles.push_back(ob);
  }
}

// Duplicate keys (which nlohmann silently resolves to the last one) and absurd nesting, found while
// parsing, with the JSON path of the offending key.
struct StrictnessError {
  std::string path, problem;
};

struct Frame {
  bool object = false;
  std::string key;
  int64_t index = -1;
  std::set<std::string> keys;
};

std::string frames_path(const std::vector<Frame>& frames) {
  std::string p;
  for (size_t i = 0; i + 1 < frames.size(); ++i) {
    if (frames[i].object)
      p = child(p, frames[i].key);
    else
      p = child(p, size_t(frames[i].index));
  }
  return p;
}

// json::parse's DOM builder with the strictness checks, as a SAX handler. Not json::parse with a
// callback: nlohmann 3.11's callback builder rescans the enclosing array for a discarded value after every
// object it closes (json_sax_dom_callback_parser::end_object), quadratic in an array of objects (400 000
// `{}` in `fingers` took 21 s to be refused). The same events reach the checks, at the depths the callback
// saw, so the same inputs are refused with the same messages.
class StrictDomBuilder {
 public:
  explicit StrictDomBuilder(json& root) : dom_(root) {}

  bool null() { return value() && dom_.null(); }
  bool boolean(bool v) { return value() && dom_.boolean(v); }
  bool number_integer(json::number_integer_t v) { return value() && dom_.number_integer(v); }
  bool number_unsigned(json::number_unsigned_t v) { return value() && dom_.number_unsigned(v); }
  bool number_float(json::number_float_t v, const json::string_t& text) { return value() && dom_.number_float(v, text); }
  bool string(json::string_t& v) { return value() && dom_.string(v); }
  bool binary(json::binary_t& v) { return value() && dom_.binary(v); }
  bool start_object(std::size_t n) { return open(true) && dom_.start_object(n); }
  bool start_array(std::size_t n) { return open(false) && dom_.start_array(n); }
  bool end_object() { return close() && dom_.end_object(); }
  bool end_array() { return close() && dom_.end_array(); }
  bool key(json::string_t& k) {
    check_depth(frames_.size());
    Frame& top = frames_.back();
    top.key = k;
    if (!top.keys.insert(top.key).second) throw StrictnessError{child(frames_path(frames_), top.key), "duplicate key"};
    return dom_.key(k);
  }
  template <class Exception>
  bool parse_error(std::size_t position, const std::string& token, const Exception& e) {
    return dom_.parse_error(position, token, e);  // throws e
  }

 private:
  static void check_depth(size_t depth) {
    if (depth > static_cast<size_t>(kMaxDepth))
      throw StrictnessError{"", "nesting deeper than " + std::to_string(kMaxDepth) + " levels"};
  }
  bool value() {
    check_depth(frames_.size());
    if (!frames_.empty() && !frames_.back().object) ++frames_.back().index;
    return true;
  }
  bool open(bool object) {
    check_depth(frames_.size());
    if (!frames_.empty() && !frames_.back().object) ++frames_.back().index;
    frames_.push_back(Frame{object, {}, -1, {}});
    return true;
  }
  bool close() {
    check_depth(frames_.size() - 1);
    frames_.pop_back();
    return true;
  }

  nlohmann::detail::json_sax_dom_parser<json> dom_;
  std::vector<Frame> frames_;
};

json parse_json_strict(const std::string& text, const std::string& file) {
  json root;
  StrictDomBuilder builder(root);
  try {
    json::sax_parse(text, &builder);
    return root;
  } catch (const StrictnessError& e) {
    fail(file, e.path, e.problem);
  } catch (const json::parse_error& e) {
    // nlohmann's text is "[json.exception.parse_error.101] parse error at line L, column C: why"; keep "why".
    std::string why = e.what();
    const size_t colon = why.find(": ", why.find("column"));
    if (colon != std::string::npos) why = why.substr(colon + 2);
    const size_t at = std::string(e.what()).find("line ");
    std::string where;
    if (at != std::string::npos) {
      const std::string w = e.what();
      where = " (" + w.substr(at, w.find(':', at) - at) + ")";
    }
    // nlohmann counts bytes from 1; report the 0-based offset that hex editors and `dd skip=` use.
    const size_t offset = e.byte > 0 ? e.byte - 1 : 0;
    fail(file, "", "malformed JSON at byte " + std::to_string(offset) + where + ": " + why);
  } catch (const json::exception& e) {
    std::string why = e.what();
    const size_t b = why.find("] ");
    if (b != std::string::npos) why = why.substr(b + 2);
    fail(file, "", "malformed JSON: " + why);
  }
}

bool is_safe_name(const std::string& name) {
  if (name.empty() || name == "." || name == ".." || name.size() > 200) return false;
  for (const unsigned char c : name)
    if (c < 0x20 || c == 0x7f || c == '/' || c == '\\') return false;
  return true;
}

std::string fmt_bytes(double bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, bytes >= 1e9 ? "%.1f GB" : "%.0f MB", bytes >= 1e9 ? bytes / 1e9 : bytes / 1e6);
  return buf;
}

// How far from the origin the scenario can take the sheet (m, largest coordinate): carried by the keys (a
// hand's rotation swings a finger about the hand's centroid, at most twice the farthest point away from
// it, and its translation adds) and falling freely for the whole run, ½ |g| T² (damping ignored: an upper
// bound).
struct SheetReach {
  double carried = 0;
  double fall = 0;
};

SheetReach sheet_reach(const Scenario& s, const std::vector<Vec2>& outline) {
  double farthest = 0, translate = 0;
  for (const Vec2& p : outline) farthest = std::max(farthest, p.cwiseAbs().maxCoeff());
  for (const FingerSpec& f : s.fingers)
    for (const FingerKey& k : f.keys) farthest = std::max(farthest, k.position.cwiseAbs().maxCoeff());
  for (const HandSpec& h : s.hands)
    for (const HandKey& k : h.keys) translate = std::max(translate, k.translate.cwiseAbs().maxCoeff());
  SheetReach r;
  r.carried = 3 * farthest + translate;
  const double duration = s.sim.frames / s.sim.fps;
  r.fall = 0.5 * s.sim.gravity.norm() * duration * duration;
  return r;
}

void validate_key_times(const std::string& file, const std::string& keys_path, const std::vector<double>& times) {
  for (size_t k = 0; k < times.size(); ++k) {
    const std::string p = child(child(keys_path, k), size_t(0));
    check_range(file, p, times[k], 0, kMaxKeyTime, false);
    if (k > 0 && !(times[k] > times[k - 1]))
      fail(file, p, "key times must increase (" + fmt(times[k]) + " after " + fmt(times[k - 1]) + ")");
  }
}

void validate_interpolation(const std::string& file, const std::string& path, const std::string& name) {
  KeyInterpolation unused;
  if (!key_interpolation_from_name(name, unused))
    fail(file, path, "unknown interpolation \"" + name + "\" (linear or smooth)");
}

// True when the open rectangle lo < p < hi and the outline's interior overlap: an outline edge with a
// piece of positive length inside the rectangle (Liang–Barsky clip), or the rectangle inside the outline.
bool outline_overlaps_rectangle(const std::vector<Vec2>& outline, const Vec2& lo, const Vec2& hi) {
  for (size_t i = 0; i < outline.size(); ++i) {
    const Vec2 a = outline[i], d = outline[(i + 1) % outline.size()] - a;
    double enter = 0, leave = 1;
    bool inside = true;
    for (int k = 0; k < 2 && inside; ++k) {
      if (d[k] == 0) {
        inside = a[k] > lo[k] && a[k] < hi[k];
        continue;
      }
      double t0 = (lo[k] - a[k]) / d[k], t1 = (hi[k] - a[k]) / d[k];
      if (t0 > t1) std::swap(t0, t1);
      enter = std::max(enter, t0);
      leave = std::min(leave, t1);
    }
    if (inside && enter < leave) return true;
  }
  return point_on_sheet(outline, 0.5 * (lo + hi));
}

void validate_obstacles(const Scenario& s, const std::vector<Vec2>& outline) {
  const std::string& file = s.path;
  if (s.obstacles.size() > static_cast<size_t>(kMaxObstacles))
    fail(file, "obstacles", "absurd size: " + std::to_string(s.obstacles.size()) + " obstacles (at most " +
                                std::to_string(kMaxObstacles) + ")");
  for (size_t i = 0; i < s.obstacles.size(); ++i) {
    const Obstacle& o = s.obstacles[i];
    const std::string p = child("obstacles", i);
    check_non_negative(file, child(p, "friction"), o.friction);
    if (o.friction > kMaxFriction)
      fail(file, child(p, "friction"), "absurd friction " + fmt(o.friction) + " (at most " + fmt(kMaxFriction) + ")");
    if (o.kind == Obstacle::Kind::Plane) {
      check_vec(file, child(p, "point"), o.point.data(), 3, kMaxCoordinate);
      check_vec(file, child(p, "normal"), o.normal.data(), 3, std::numeric_limits<double>::max());
      if (!(o.normal.cwiseAbs().maxCoeff() > 0)) fail(file, child(p, "normal"), "must be non-zero");
      // The sheet starts flat in the plane z = 0 over its outline: the outline's corners are its extremes.
      const Vec3 n = (o.normal / o.normal.cwiseAbs().maxCoeff()).normalized();  // scaled first: a tiny one underflows
      for (const Vec2& q : outline)
        if (n.dot(Vec3(q.x(), q.y(), 0) - o.point) < 0)
          fail(file, p, "the sheet starts below this plane (its corner " + fmt_uv(q) + " is on the far side of the normal)");
    } else {
      check_vec(file, child(p, "min"), o.min.data(), 3, kMaxCoordinate);
      check_vec(file, child(p, "max"), o.max.data(), 3, kMaxCoordinate);
      for (int a = 0; a < 3; ++a)
        if (!(o.max[a] > o.min[a]))
          fail(file, child(child(p, "max"), size_t(a)),
               "must exceed min[" + std::to_string(a) + "] (" + fmt(o.max[a]) + " <= " + fmt(o.min[a]) + ")");
      if (o.min.z() < 0 && o.max.z() > 0 && outline_overlaps_rectangle(outline, o.min.head<2>(), o.max.head<2>()))
        fail(file, p, "the sheet starts inside this box (it lies in z = 0 over its outline)");
    }
  }
}

// Sheet: the outline (`outline`, at `outline_path` in the file) and the mesh it asks for.
void validate_sheet(const Scenario& s, const std::vector<Vec2>& outline, const std::string& outline_path) {
  const std::string& file = s.path;
  for (size_t i = 0; i < outline.size(); ++i)
    check_vec(file, child(outline_path, i), outline[i].data(), 2, kMaxCoordinate);
  if (const std::string problem = outline_problem(outline); !problem.empty()) fail(file, outline_path, problem);
  check_int(file, "sheet.triangles", s.triangles, kMinTriangles, kMaxTriangles);
  // What `run` would refuse while meshing, where a lower bound on any quality mesh already shows it (a
  // 0.3 m x 1e-7 m strip). Fingers count as points so that check never refuses what run meshes.
  {
    const double min_angle = MeshRequest{}.min_angle_deg;
    const double needed = min_quality_triangles(outline, min_angle);
    const int64_t limit = max_mesh_triangles(s.triangles, static_cast<int64_t>(outline.size() + s.fingers.size()));
    if (needed > static_cast<double>(limit))
      fail(file, outline_path,
           "features far finer than a mesh of " + std::to_string(s.triangles) + " triangles (a narrow strip or a short "
           "edge): any mesh of it with angles of at least " + fmt(min_angle) + " deg has " + fmt(needed) +
           " triangles or more (tan(angle) perimeter^2 / 36 area), above " + std::to_string(limit));
  }
  if (s.triangles > kMaxSheetTriangles)
    fail(file, "sheet.triangles",
         std::to_string(s.triangles) + " triangles would take about " + fmt_bytes(estimated_sheet_bytes(s.triangles)) +
             " of memory; at most " + std::to_string(kMaxSheetTriangles) + " (about " +
             fmt_bytes(estimated_sheet_bytes(kMaxSheetTriangles)) + ") are accepted (docs/memory.md)");
  check_finite(file, "sheet.mesh_rotation_deg", s.mesh_rotation_deg);
}

void validate_material(const Scenario& s) {
  const std::string& file = s.path;
  const Material& m = s.material;
  check_positive(file, "material.thickness", m.thickness);
  check_plausible(file, "material.thickness", m.thickness, kMinThickness, kMaxThickness, "m");
  check_positive(file, "material.density", m.density);
  check_plausible(file, "material.density", m.density, kMinDensity, kMaxDensity, "kg/m^3");
  check_positive(file, "material.young", m.young);
  check_plausible(file, "material.young", m.young, kMinYoung, kMaxYoung, "Pa");
  check_range(file, "material.poisson", m.poisson, 0, 0.5, true);
  check_non_negative(file, "material.bending_scale", m.bending_scale);
  check_plausible(file, "material.bending_scale", m.bending_scale, 0, kMaxBendingScale, "");
  check_range(file, "material.membrane_scale", m.membrane_scale, 0, 1, false);
  if (!(m.membrane_scale > 0)) fail(file, "material.membrane_scale", "must be > 0 (a fraction of young, at most 1)");
  check_positive(file, "material.strain_limit", m.strain_limit);
  check_range(file, "material.compression_scale", m.compression_scale, 0, 1, false);
  if (!(m.compression_scale > 0))
    fail(file, "material.compression_scale", "must be > 0 (a fraction of the compressive stiffness, at most 1)");
  check_positive(file, "material.compression_limit", m.compression_limit);
  check_non_negative(file, "material.damping", m.damping);
  check_range(file, "material.tip_damage", m.tip_damage, 0, 1, false);
  check_positive(file, "material.fiber_scale", m.fiber_scale);
  check_plausible(file, "material.fracture_c", m.fracture_c, kMinFractureC, kMaxFractureC, "J/m^2");
  check_non_negative(file, "material.speed", m.speed);
  check_positive(file, "material.max_step", m.max_step);
  check_range(file, "material.fiber_floor", m.fiber_floor, 0, 1, false);
  check_non_negative(file, "material.min_step", m.min_step);
}

void validate_detail(const Scenario& s) {
  const std::string& file = s.path;
  const auto& tex = s.detail.texture;
  for (size_t i = 0; i < 2; ++i) check_int(file, child("detail.texture", i), tex[i], 0, kMaxTexture);
  if ((tex[0] == 0) != (tex[1] == 0))
    fail(file, "detail.texture", "give both width and height, or [0, 0] for the default resolution");
  check_positive(file, "detail.sigma", s.detail.sigma);
  check_range(file, "detail.omega", s.detail.omega, 0, 1, false);
}

void validate_sim(const Scenario& s) {
  const std::string& file = s.path;
  check_positive(file, "sim.fps", s.sim.fps);
  check_plausible(file, "sim.fps", s.sim.fps, kMinFps, kMaxFps, "frames/s");
  check_int(file, "sim.substeps", s.sim.substeps, 1, kMaxSubsteps);
  check_int(file, "sim.frames", s.sim.frames, 1, kMaxFrames);
  check_int(file, "sim.iterations", s.sim.iterations, 1, kMaxIterations);
  check_int(file, "sim.step_splits", s.sim.step_splits, 0, kMaxStepSplits);
  check_positive(file, "sim.split_strain_jump", s.sim.split_strain_jump);
  check_range(file, "sim.split_strain_jump", s.sim.split_strain_jump, 0, 1, false);
  check_vec(file, "sim.gravity", s.sim.gravity.data(), 3, kMaxGravity);
  // Projective dynamics was measured out (docs/architecture.md "Physics"): a file that asks for it is refused
  // by name rather than run with the other solver.
  if (s.sim.solver == "projective")
    fail(file, "sim.solver",
         "\"projective\" is no longer offered: it left 6-11% stretch and tore sheets that must not tear; use \"implicit\"");
  if (s.sim.solver != "implicit") fail(file, "sim.solver", "unknown solver \"" + s.sim.solver + "\" (implicit)");
  if (s.sim.relaxation != "substep" && s.sim.relaxation != "next_frame" && s.sim.relaxation != "patch")
    fail(file, "sim.relaxation", "unknown relaxation \"" + s.sim.relaxation + "\" (substep, next_frame or patch)");
  check_positive(file, "sim.relaxation_radius", s.sim.relaxation_radius);
  if (s.sim.relaxation_radius > kMaxCoordinate)
    fail(file, "sim.relaxation_radius",
         "absurd size " + fmt(s.sim.relaxation_radius) + " (at most " + fmt(kMaxCoordinate) + ")");
  check_positive(file, "sim.self_contact.gap", s.sim.self_contact.gap);
  if (s.sim.self_contact.gap > kMaxSelfContactGap)
    fail(file, "sim.self_contact.gap",
         "absurd size " + fmt(s.sim.self_contact.gap) + " (at most " + fmt(kMaxSelfContactGap) + " m)");
  check_range(file, "sim.self_contact.friction", s.sim.self_contact.friction, 0, kMaxFriction, false);
}

void validate_tearing(const Scenario& s) {
  const std::string& file = s.path;
  // The names the tearing step knows (systems/tearing/tearing_step.hpp): "fan" is the bisector's other name.
  if (TearDirection d; !tear_direction_from_name(s.tearing.direction, d))
    fail(file, "tearing.direction",
         "unknown direction \"" + s.tearing.direction + "\" (tension_rays, fan, bisector or material_force)");
  check_positive(file, "tearing.radius", s.tearing.radius);
  if (s.tearing.radius > kMaxCoordinate)
    fail(file, "tearing.radius", "absurd size " + fmt(s.tearing.radius) + " (at most " + fmt(kMaxCoordinate) + ")");
  if (s.tearing.snap) check_range(file, "tearing.snap", *s.tearing.snap, 0, 0.45, false);
  // Lengths in the pattern: zero turns shielding, the wrap's tolerance and the bearing's length off; the
  // start's edge length and the disc it is read over must be positive.
  check_range(file, "tearing.shielding_radius", s.tearing.shielding_radius, 0, kMaxCoordinate, false);
  check_range(file, "tearing.start_wrap", s.tearing.start_wrap, 0, kMaxCoordinate, false);
  check_range(file, "tearing.bearing_length", s.tearing.bearing_length, 0, kMaxCoordinate, false);
  check_range(file, "tearing.opening_floor", s.tearing.opening_floor, 0, 1, false);
  for (const auto& [key, value] : {std::pair<const char*, double>{"tearing.start_length", s.tearing.start_length},
                                   {"tearing.edge_radius", s.tearing.edge_radius}}) {
    check_positive(file, key, value);
    if (value > kMaxCoordinate)
      fail(file, key, "absurd size " + fmt(value) + " (at most " + fmt(kMaxCoordinate) + ")");
  }
  // A turn of 0 would stop every tip after its first segment; past 180 degrees any direction passes.
  check_range(file, "tearing.max_turn_deg", s.tearing.max_turn_deg, 0, 180, false);
  if (!(s.tearing.max_turn_deg > 0)) fail(file, "tearing.max_turn_deg", "must be positive, got 0");
}

// Fingers. None is fine in code (a sheet falling freely); files must have some (parse_scenario).
void validate_fingers(const Scenario& s, const std::vector<Vec2>& outline) {
  const std::string& file = s.path;
  for (size_t i = 0; i < s.fingers.size(); ++i) {
    const FingerSpec& f = s.fingers[i];
    const std::string p = child("fingers", i);
    if (f.name.empty()) fail(file, child(p, "name"), "must not be empty");
    for (size_t k = 0; k < i; ++k)
      if (s.fingers[k].name == f.name) fail(file, child(p, "name"), "duplicate finger name \"" + f.name + "\"");
    check_vec(file, child(p, "at"), f.at.data(), 2, kMaxCoordinate);
    if (!point_on_sheet(outline, f.at))  // the mesher's test: what check accepts, run meshes
      fail(file, child(p, "at"), "finger " + f.name + " at " + fmt_uv(f.at) + " is outside the sheet");
    // Two fingers may hold the same point one after the other, not at once.
    for (size_t k = 0; k < i; ++k) {
      const FingerSpec& o = s.fingers[k];
      if ((o.at - f.at).norm() < 1e-9 && f.attach < o.release && o.attach < f.release)
        fail(file, child(p, "at"), "finger " + f.name + " is at the same point as finger " + o.name +
                                       " while both hold it");
    }
    std::vector<double> times;
    for (size_t k = 0; k < f.keys.size(); ++k) {
      times.push_back(f.keys[k].t);
      check_vec(file, child(child(child(p, "keys"), k), size_t(1)), f.keys[k].position.data(), 3, kMaxCoordinate);
    }
    validate_key_times(file, child(p, "keys"), times);
    validate_interpolation(file, child(p, "interpolation"), f.interpolation);
    if (!std::isfinite(f.attach) || f.attach < 0) fail(file, child(p, "attach"), "must be a time ≥ 0");
    if (!(f.release > f.attach)) fail(file, child(p, "release"), "must come after attach");
    check_positive(file, child(p, "grip"), f.grip);
    if (f.grip > kMaxGrip) fail(file, child(p, "grip"), "absurd grip " + fmt(f.grip) + " N (at most " + fmt(kMaxGrip) + ")");
    if (!std::isfinite(f.pad) || f.pad < 0 || f.pad > kMaxPad)
      fail(file, child(p, "pad"), "a pad's radius is 0 (a point) to " + fmt(kMaxPad) + " m, not " + fmt(f.pad));
  }
}

void validate_hands(const Scenario& s) {
  const std::string& file = s.path;
  std::vector<int> owner(s.fingers.size(), -1);
  for (size_t i = 0; i < s.hands.size(); ++i) {
    const HandSpec& h = s.hands[i];
    const std::string p = child("hands", i);
    if (h.name.empty()) fail(file, child(p, "name"), "must not be empty");
    for (size_t k = 0; k < i; ++k)
      if (s.hands[k].name == h.name) fail(file, child(p, "name"), "duplicate hand name \"" + h.name + "\"");
    if (h.fingers.empty()) fail(file, child(p, "fingers"), "a hand needs at least one finger");
    for (size_t k = 0; k < h.fingers.size(); ++k) {
      const std::string fp = child(child(p, "fingers"), k);
      size_t f = 0;
      while (f < s.fingers.size() && s.fingers[f].name != h.fingers[k]) ++f;
      if (f == s.fingers.size()) fail(file, fp, "unknown finger \"" + h.fingers[k] + "\"");
      if (owner[f] == static_cast<int>(i)) fail(file, fp, "finger \"" + h.fingers[k] + "\" listed twice");
      if (owner[f] >= 0)
        fail(file, fp, "finger \"" + h.fingers[k] + "\" already belongs to hand \"" + s.hands[owner[f]].name + "\"");
      owner[f] = static_cast<int>(i);
    }
    std::vector<double> times;
    for (size_t k = 0; k < h.keys.size(); ++k) {
      const HandKey& key = h.keys[k];
      const std::string kp = child(child(child(p, "keys"), k), size_t(1));
      times.push_back(key.t);
      check_vec(file, child(kp, "translate"), key.translate.data(), 3, kMaxCoordinate);
      check_finite(file, child(kp, "rotate_deg"), key.rotate_deg);
      check_vec(file, child(kp, "axis"), key.axis.data(), 3, std::numeric_limits<double>::max());
      // Any finite non-zero vector is a direction (apply_hand_motion scales it before normalising).
      if (!(key.axis.cwiseAbs().maxCoeff() > 0)) fail(file, child(kp, "axis"), "rotation axis must be non-zero");
    }
    validate_key_times(file, child(p, "keys"), times);
    validate_interpolation(file, child(p, "interpolation"), h.interpolation);
  }
}

// Far from the origin doubles do not resolve the sheet's strains (engine/scenario.hpp).
void validate_sheet_reach(const Scenario& s, const std::vector<Vec2>& outline) {
  const std::string& file = s.path;
  const SheetReach reach = sheet_reach(s, outline);
  if (reach.carried + reach.fall > kMaxSheetPosition) {
    const double room = std::max(0.0, kMaxSheetPosition - reach.carried);
    const double g = s.sim.gravity.norm();
    const double max_frames = std::floor(std::sqrt(2 * room / g) * s.sim.fps);
    fail(file, "sim.frames",
         std::to_string(s.sim.frames) + " frames at " + fmt(s.sim.fps) + " frames/s under a gravity of " + fmt(g) +
             " m/s^2 let a released sheet fall " + fmt(reach.fall) + " m, beyond the +-" + fmt(kMaxSheetPosition) +
             " m within which positions are resolved; at most " + fmt(max_frames) + " frames");
  }
}

}  // namespace

void validate_scenario(const Scenario& s) {
  const std::string& file = s.path;
  // An empty name is fine for scenarios built in code; files always get one (default: the file stem).
  if (!s.name.empty() && !is_safe_name(s.name))
    fail(file, "name", "\"" + s.name + "\" cannot name an output directory (empty, '.', '..', '/' or control characters)");

  // Sheet. A scenario built in code may name a preset and leave the outline to the sheet builder.
  const std::string outline_path = s.preset.empty() ? "sheet.outline" : "sheet.preset";
  std::vector<Vec2> preset;
  if (s.outline.empty() && !s.preset.empty()) {
    try {
      preset = preset_outline(s.preset);
    } catch (const GeometryError& e) {
      fail(file, outline_path, e.what());
    }
  }
  const std::vector<Vec2>& outline = preset.empty() ? s.outline : preset;
  validate_sheet(s, outline, outline_path);
  validate_material(s);
  validate_detail(s);
  validate_sim(s);
  validate_tearing(s);
  validate_fingers(s, outline);
  validate_hands(s);
  validate_obstacles(s, outline);
  validate_sheet_reach(s, outline);
}

double estimated_sheet_bytes(int64_t triangles) {
  // Peak RSS of one frame of scenarios/demo.json (/usr/bin/time -v, 2 threads): 299 MB at 49 860
  // triangles, 621 MB at 99 714, 1 319 MB at 199 531, within 2% of this; the solver's factor fills like
  // n log n. 2 000 000 triangles: 15.7 GB.
  const double n = static_cast<double>(std::max<int64_t>(triangles, 2));
  return 10e6 + 375.0 * n * std::log2(n);
}

namespace {
Scenario parse_document(const std::string& json_text, const std::string& path_for_messages, bool fingers_required) {
  const std::string& file = path_for_messages;
  if (json_text.find_first_not_of(" \t\r\n") == std::string::npos)
    fail(file, "", "empty file (expected a JSON scenario object)");
  // A NUL byte never occurs in JSON text: say "binary" rather than echo garbage from the parser.
  if (const size_t nul = json_text.find('\0'); nul != std::string::npos)
    fail(file, "", "not a JSON text file (binary data at byte " + std::to_string(nul) + ")");

  const json root = parse_json_strict(json_text, file);
  if (!root.is_object()) fail(file, "", std::string("expected a JSON object at the top level, got ") + type_name(root));

  const Reader r{file};
  r.check_keys(root, "",
               {"name", "description", "version", "sheet", "material", "detail", "sim", "tearing", "fingers", "hands",
                "obstacles"});

  Scenario s;
  s.path = file;
  if (root.contains("name")) {
    s.name = r.string(root["name"], "name");
    // A file's name is its output directory, out/<name>: empty would be out/ itself.
    if (s.name.empty()) fail(file, "name", "must not be empty (it names the output directory out/<name>)");
  } else {
    s.name = std::filesystem::path(file).stem().string();
    if (s.name.empty()) s.name = "scenario";
  }
  if (root.contains("description")) s.description = r.string(root["description"], "description");
  if (root.contains("version")) {
    const int64_t version = r.integer(root["version"], "version", 1, 1'000'000);
    if (version != 1) fail(file, "version", "unsupported scenario version " + std::to_string(version) + " (this papertear reads version 1)");
  }
  if (!root.contains("sheet")) fail(file, "sheet", "missing (an outline or a preset is required)");
  read_sheet(r, root["sheet"], s);
  if (root.contains("material")) read_material(r, root["material"], s.material);
  if (root.contains("detail")) read_detail(r, root["detail"], s.detail);
  if (root.contains("sim")) read_sim(r, root["sim"], s.sim);
  if (root.contains("tearing")) read_tearing(r, root["tearing"], s.tearing);
  if (!root.contains("fingers") && fingers_required) fail(file, "fingers", "missing (at least one finger is required)");
  if (root.contains("fingers")) read_fingers(r, root["fingers"], s.fingers);
  if (s.fingers.empty() && fingers_required) fail(file, "fingers", "at least one finger is required");
  if (root.contains("hands")) read_hands(r, root["hands"], s.hands);
  if (root.contains("obstacles")) read_obstacles(r, root["obstacles"], s.obstacles);

  validate_scenario(s);
  return s;
}
}  // namespace

Scenario parse_scenario(const std::string& json_text, const std::string& path_for_messages) {
  return parse_document(json_text, path_for_messages, true);
}

Scenario parse_scenario_in_code(const std::string& json_text, const std::string& path_for_messages) {
  return parse_document(json_text, path_for_messages, false);
}

namespace {

std::string read_scenario_text(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) fail(path, "", "is a directory, not a scenario file");
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) fail(path, "", std::string("cannot open: ") + std::strerror(errno));
  std::string text;
  char buf[1 << 16];
  bool too_big = false, read_error = false;
  for (;;) {
    const size_t n = std::fread(buf, 1, sizeof buf, f);
    text.append(buf, n);
    if (static_cast<int64_t>(text.size()) > kMaxFileBytes) {
      too_big = true;
      break;
    }
    if (n < sizeof buf) {
      read_error = std::ferror(f) != 0;
      break;
    }
  }
  const int err = errno;
  std::fclose(f);
  if (read_error) fail(path, "", std::string("cannot read: ") + std::strerror(err));
  if (too_big) fail(path, "", "absurd size: file larger than " + std::to_string(kMaxFileBytes >> 20) + " MiB");
  return text;
}

// A setting as echoed in an error's one line: a long one by its beginning.
std::string shown(const std::string& setting) {
  return setting.size() <= 80 ? setting : setting.substr(0, 60) + "... (" + std::to_string(setting.size()) + " bytes)";
}

// The offset of the first byte that is not part of well-formed UTF-8 (RFC 3629), npos when all is.
size_t invalid_utf8_at(std::string_view s) {
  for (size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    size_t n = 0;
    unsigned char lo = 0x80, hi = 0xbf;  // the range of the second byte
    if (c < 0x80) n = 1;
    else if (c >= 0xc2 && c <= 0xdf) n = 2;
    else if (c >= 0xe0 && c <= 0xef) n = 3, lo = c == 0xe0 ? 0xa0 : 0x80, hi = c == 0xed ? 0x9f : 0xbf;
    else if (c >= 0xf0 && c <= 0xf4) n = 4, lo = c == 0xf0 ? 0x90 : 0x80, hi = c == 0xf4 ? 0x8f : 0xbf;
    else return i;
    if (i + n > s.size()) return i;
    for (size_t k = 1; k < n; ++k) {
      const auto b = static_cast<unsigned char>(s[i + k]);
      if (k == 1 ? (b < lo || b > hi) : (b < 0x80 || b > 0xbf)) return i;
    }
    i += n;
  }
  return std::string_view::npos;
}

// JSON's number grammar (RFC 8259 §6): a value that is one but does not parse is out of a double's range.
bool is_json_number(std::string_view t) {
  size_t i = 0;
  const auto digits = [&] {
    const size_t from = i;
    while (i < t.size() && t[i] >= '0' && t[i] <= '9') ++i;
    return i > from;
  };
  if (i < t.size() && t[i] == '-') ++i;
  if (i < t.size() && t[i] == '0') ++i;
  else if (!digits()) return false;
  if (i < t.size() && t[i] == '.' && (++i, !digits())) return false;
  if (i < t.size() && (t[i] == 'e' || t[i] == 'E')) {
    ++i;
    if (i < t.size() && (t[i] == '+' || t[i] == '-')) ++i;
    if (!digits()) return false;
  }
  return i == t.size();
}

// "a.b.c=VALUE" of --set written into the document: VALUE as JSON when it is JSON (0.05, true, [1, 2],
// "text"), else as a string (patch); objects on the way are created where missing. A setting that is not
// UTF-8 (JSON text is) or a number beyond a double's range is refused rather than stored as text.
void apply_setting(const std::string& path, const std::string& setting, json& root) {
  const std::string where = "--set " + shown(setting);
  if (const size_t bad = invalid_utf8_at(setting); bad != std::string_view::npos)
    fail(path, "", where + ": not UTF-8 text (byte " + std::to_string(bad) + ")");
  const size_t eq = setting.find('=');
  if (eq == std::string::npos || eq == 0) fail(path, "", where + ": expected KEY=VALUE");
  const std::string key = setting.substr(0, eq), text = setting.substr(eq + 1);
  std::vector<std::string> parts;
  for (size_t begin = 0;;) {
    const size_t dot = key.find('.', begin);
    parts.push_back(key.substr(begin, dot == std::string::npos ? std::string::npos : dot - begin));
    if (parts.back().empty()) fail(path, "", where + ": empty name in the key");
    if (parts.size() > static_cast<size_t>(kMaxDepth))
      fail(path, "", where + ": key deeper than " + std::to_string(kMaxDepth) + " levels");
    if (dot == std::string::npos) break;
    begin = dot + 1;
  }
  json* node = &root;
  std::string walked;
  for (size_t i = 0; i + 1 < parts.size(); ++i) {
    walked += (i ? "." : "") + parts[i];
    json& next = (*node)[parts[i]];
    if (next.is_null()) next = json::object();
    if (!next.is_object()) fail(path, walked, where + ": not an object (" + type_name(next) + ")");
    node = &next;
  }
  // The strict parser, so a value nests no deeper than a file may (dump and the checks recurse).
  const bool is_json = json::accept(text);
  if (!is_json && is_json_number(text))
    fail(path, "", where + ": " + shown(text) + " is out of the range of a number (at most about 1.8e308 in magnitude)");
  json value;
  try {
    value = is_json ? parse_json_strict(text, path) : json(text);
  } catch (const InputError& e) {
    throw InputError(std::string(e.what()) + " (in " + where + ")");
  }
  (*node)[parts.back()] = std::move(value);
}

}  // namespace

Scenario load_scenario(const std::string& path) { return parse_scenario(read_scenario_text(path), path); }

Scenario load_scenario(const std::string& path, const std::vector<std::string>& settings) {
  if (settings.empty()) return load_scenario(path);
  json root = parse_json_strict(read_scenario_text(path), path);
  if (!root.is_object()) fail(path, "", std::string("expected a JSON object at the top level, got ") + type_name(root));
  for (const std::string& setting : settings) apply_setting(path, setting, root);
  try {
    return parse_scenario(root.dump(), path);
  } catch (const InputError& e) {
    std::string all;
    for (const std::string& setting : settings) all += (all.empty() ? "" : ", ") + shown(setting);
    throw InputError(std::string(e.what()) + " (with --set " + all + ")");
  }
}

}  // namespace pt
