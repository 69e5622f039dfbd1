#include "apps/viewer/recorder.hpp"

#include "engine/simulation_internals.hpp"
#include "systems/physics/fingers.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <stdexcept>

namespace pt::viewer {

namespace {

using json = nlohmann::json;

json vec(const Vec2& v) { return json::array({v.x(), v.y()}); }
json vec(const Vec3& v) { return json::array({v.x(), v.y(), v.z()}); }

bool in_scenario(const Scenario& s, const std::string& finger) {
  for (const FingerSpec& f : s.fingers)
    if (f.name == finger) return true;
  return false;
}

}  // namespace

json session_json(const Simulation& sim, const std::string& name) {
  const Scenario& sc = sim.scenario();
  const Sheet& sheet = sim.sheet();
  json j = json::object();
  j["name"] = name.empty() ? (sc.name.empty() ? std::string("session") : sc.name + "-session") : name;
  j["description"] = "Interactive session recorded by papertear-viewer from " +
                     (sc.path.empty() ? std::string("a built-in scenario") : sc.path) + ", " +
                     std::to_string(sim.frame()) + " frames.";

  json sh = json::object();
  if (!sc.preset.empty()) {
    sh["preset"] = sc.preset;
  } else {
    json o = json::array();
    for (const Vec2& p : sc.outline) o.push_back(vec(p));
    sh["outline"] = o;
  }
  sh["triangles"] = sc.triangles;
  sh["mesh_seed"] = sc.mesh_seed;
  sh["mesh_rotation_deg"] = sc.mesh_rotation_deg;
  j["sheet"] = sh;

  const Material& m = sheet.material;
  j["material"] = {{"thickness", m.thickness},   {"density", m.density},         {"young", m.young},
                   {"poisson", m.poisson},       {"bending_scale", m.bending_scale}, {"damping", m.damping},
                   {"tip_damage", m.tip_damage}, {"fiber_seed", m.fiber_seed},   {"fiber_scale", m.fiber_scale},
                   {"fracture_c", m.fracture_c}, {"speed", m.speed},             {"max_step", m.max_step},
                   {"min_step", m.min_step},     {"fiber_floor", m.fiber_floor},
                   {"membrane_scale", m.membrane_scale}, {"strain_limit", m.strain_limit},
                   {"compression_scale", m.compression_scale}, {"compression_limit", m.compression_limit}};

  // The detail noise as the simulation has it now (the viewer sets it live).
  json d = {{"sigma", detail_params(sim).sigma}, {"omega", detail_params(sim).omega}};
  if (sc.detail.texture[0] > 0 && sc.detail.texture[1] > 0)
    d["texture"] = json::array({sc.detail.texture[0], sc.detail.texture[1]});
  j["detail"] = d;

  j["sim"] = {{"fps", sc.sim.fps},
              {"substeps", sc.sim.substeps},
              {"frames", std::max(1, sim.frame())},
              {"gravity", vec(sc.sim.gravity)},
              {"iterations", sc.sim.iterations},
              {"solver", sc.sim.solver},
              {"relaxation", sc.sim.relaxation},
              {"relaxation_radius", sc.sim.relaxation_radius},
              {"step_splits", sc.sim.step_splits},
              {"split_strain_jump", sc.sim.split_strain_jump}};
  j["tearing"] = {{"direction", sc.tearing.direction}, {"radius", sc.tearing.radius}};
  if (sc.tearing.snap) j["tearing"]["snap"] = *sc.tearing.snap;

  json fingers = json::array();
  for (const Finger& f : sheet.fingers) {
    json jf = {{"name", f.name}, {"at", vec(f.uv)}};
    json keys = json::array();
    for (const FingerKey& k : f.keys) keys.push_back(json::array({k.t, vec(k.position)}));
    jf["keys"] = keys;
    if (f.interpolation != KeyInterpolation::linear) jf["interpolation"] = key_interpolation_name(f.interpolation);
    // Fingers of the scenario are on the sheet from the start (attach_time 0, a mesh vertex from the
    // meshing); fingers put on during the session are inserted at their attach time.
    if (!in_scenario(sc, f.name) || f.attach_time > 0) jf["attach"] = f.attach_time;
    jf["grip"] = f.grip;
    if (f.pad_radius > 0) jf["pad"] = f.pad_radius;
    if (f.released && std::isfinite(f.release_time) && f.release_time < 1e299) jf["release"] = f.release_time;
    fingers.push_back(jf);
  }
  j["fingers"] = fingers;

  if (!sc.hands.empty()) {
    json hands = json::array();
    for (const HandSpec& h : sc.hands) {
      json keys = json::array();
      for (const HandKey& k : h.keys)
        keys.push_back(json::array(
            {k.t, {{"translate", vec(k.translate)}, {"rotate_deg", k.rotate_deg}, {"axis", vec(k.axis)}}}));
      json jh = {{"name", h.name}, {"fingers", h.fingers}, {"keys", keys}};
      if (h.interpolation != HandSpec{}.interpolation) jh["interpolation"] = h.interpolation;
      hands.push_back(jh);
    }
    j["hands"] = hands;
  }
  return j;
}

void write_session(const Simulation& sim, const std::string& path, const std::string& name) {
  const std::string text = session_json(sim, name).dump(2) + "\n";
  const std::filesystem::path target(path);
  if (target.has_parent_path()) std::filesystem::create_directories(target.parent_path());
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw std::runtime_error("cannot write " + tmp);
    out << text;
    out.flush();
    if (!out) throw std::runtime_error("cannot write " + tmp);
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) throw std::runtime_error("cannot rename " + tmp + " to " + path + ": " + ec.message());
}

}  // namespace pt::viewer
