// papertear.Scenario: a scenario built or edited in code. Its source of truth is the scenario file it would
// be (docs/scenario-format.md): every change is written into that JSON document, which the engine's own
// parser then reads again, so a value set in code meets exactly the checks and messages of a file
// ("<file>: <json path>: <problem>", InputError) and, refused, leaves the scenario as it was. Only the
// fingers may be left out, as validate_scenario allows in code (a sheet falling freely).
#include "python/arguments.hpp"

#include <nlohmann/json.hpp>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace papertear_py {

namespace {

using json = nlohmann::ordered_json;
using namespace pybind11::literals;

json vec(const pt::Vec2& p) { return json::array({p.x(), p.y()}); }
json vec(const pt::Vec3& p) { return json::array({p.x(), p.y(), p.z()}); }

// The scenario file `s` is: every key written, defaults included, so that a reader sees every value and
// reading it back gives `s` again (doubles are written with enough digits to round-trip).
json scenario_document(const pt::Scenario& s) {
  json doc;
  if (!s.name.empty()) doc["name"] = s.name;
  if (!s.description.empty()) doc["description"] = s.description;
  json& sheet = doc["sheet"];
  if (!s.preset.empty()) {
    sheet["preset"] = s.preset;
  } else {
    json outline = json::array();
    for (const pt::Vec2& p : s.outline) outline.push_back(vec(p));
    sheet["outline"] = outline;
  }
  sheet["triangles"] = s.triangles;
  sheet["mesh_seed"] = s.mesh_seed;
  sheet["mesh_rotation_deg"] = s.mesh_rotation_deg;
  sheet["hand_lines"] = s.hand_lines;
  const pt::Material& m = s.material;
  doc["material"] = {{"thickness", m.thickness},   {"density", m.density},
                     {"young", m.young},           {"poisson", m.poisson},
                     {"bending_scale", m.bending_scale}, {"membrane_scale", m.membrane_scale},
                     {"strain_limit", m.strain_limit}, {"compression_scale", m.compression_scale},
                     {"compression_limit", m.compression_limit}, {"damping", m.damping},
                     {"tip_damage", m.tip_damage}, {"fiber_seed", m.fiber_seed},
                     {"fiber_scale", m.fiber_scale}, {"fiber_floor", m.fiber_floor},
                     {"fracture_c", m.fracture_c}, {"speed", m.speed},
                     {"max_step", m.max_step},     {"min_step", m.min_step}};
  doc["detail"] = {{"texture", json::array({s.detail.texture[0], s.detail.texture[1]})},
                   {"sigma", s.detail.sigma},
                   {"omega", s.detail.omega}};
  doc["sim"] = {{"fps", s.sim.fps},
                {"substeps", s.sim.substeps},
                {"frames", s.sim.frames},
                {"gravity", vec(s.sim.gravity)},
                {"iterations", s.sim.iterations},
                {"solver", s.sim.solver},
                {"relaxation", s.sim.relaxation},
                {"relaxation_radius", s.sim.relaxation_radius},
                {"step_splits", s.sim.step_splits},
                {"split_strain_jump", s.sim.split_strain_jump}};
  if (s.sim.self_contact.on)
    doc["sim"]["self_contact"] = {{"gap", s.sim.self_contact.gap}, {"friction", s.sim.self_contact.friction}};
  const pt::TearingSettings& t = s.tearing;
  doc["tearing"] = {{"direction", t.direction},           {"radius", t.radius},
                    {"shielding_radius", t.shielding_radius}, {"max_turn_deg", t.max_turn_deg},
                    {"start_wrap", t.start_wrap},         {"start_length", t.start_length},
                    {"edge_radius", t.edge_radius},       {"bearing_length", t.bearing_length},
                    {"opening_floor", t.opening_floor}};
  if (t.snap) doc["tearing"]["snap"] = *t.snap;
  json fingers = json::array();
  for (const pt::FingerSpec& f : s.fingers) {
    json keys = json::array();
    for (const pt::FingerKey& k : f.keys) keys.push_back(json::array({k.t, vec(k.position)}));
    json finger = {{"name", f.name}, {"at", vec(f.at)}, {"keys", keys}, {"attach", f.attach}};
    if (f.interpolation != pt::FingerSpec{}.interpolation) finger["interpolation"] = f.interpolation;
    if (f.release != pt::FingerSpec{}.release) finger["release"] = f.release;  // default: never
    finger["grip"] = f.grip;
    if (f.pad > 0) finger["pad"] = f.pad;  // default: a point
    fingers.push_back(finger);
  }
  doc["fingers"] = fingers;
  if (!s.hands.empty()) {
    json hands = json::array();
    for (const pt::HandSpec& h : s.hands) {
      json keys = json::array();
      for (const pt::HandKey& k : h.keys)
        keys.push_back(json::array(
            {k.t, {{"translate", vec(k.translate)}, {"rotate_deg", k.rotate_deg}, {"axis", vec(k.axis)}}}));
      json hand = {{"name", h.name}, {"fingers", h.fingers}, {"keys", keys}};
      if (h.interpolation != pt::HandSpec{}.interpolation) hand["interpolation"] = h.interpolation;
      hands.push_back(hand);
    }
    doc["hands"] = hands;
  }
  return doc;
}

std::string file_label(const std::string& path) { return path.empty() ? "<scenario>" : path; }

[[noreturn]] void fail(const std::string& file, const std::string& json_path, const std::string& problem) {
  throw pt::InputError(file_label(file) + ": " + (json_path.empty() ? "" : json_path + ": ") + problem);
}

std::string child(const std::string& path, const std::string& key) { return path.empty() ? key : path + "." + key; }
std::string child(const std::string& path, size_t index) { return path + "[" + std::to_string(index) + "]"; }

// A Python value as JSON: dict (str keys), list, tuple, str, int, float, bool, None; numpy scalars through
// __index__ / __float__. NaN and infinities are refused here with the parser's words, since JSON has none.
json json_from_python(py::handle v, const std::string& file, const std::string& path) {
  if (v.is_none()) return nullptr;
  if (PyBool_Check(v.ptr())) return v.ptr() == Py_True;
  if (PyUnicode_Check(v.ptr())) return v.cast<std::string>();
  if (PyLong_Check(v.ptr()) || (PyIndex_Check(v.ptr()) && !PyFloat_Check(v.ptr()))) {
    const py::object i = py::reinterpret_steal<py::object>(PyNumber_Index(v.ptr()));
    if (!i) throw py::error_already_set();
    int overflow = 0;
    const long long x = PyLong_AsLongLongAndOverflow(i.ptr(), &overflow);
    if (overflow == 0) return static_cast<int64_t>(x);
    if (overflow > 0) {
      const unsigned long long u = PyLong_AsUnsignedLongLong(i.ptr());
      if (!PyErr_Occurred()) return static_cast<uint64_t>(u);
      PyErr_Clear();
    }
    // Beyond 64 bits: a JSON number of that size reads as a double, which the range checks then refuse.
    const double d = PyLong_AsDouble(i.ptr());
    if (d == -1.0 && PyErr_Occurred()) {
      PyErr_Clear();
      fail(file, path, "absurd size: an integer beyond the range of a number");
    }
    return d;
  }
  if (PyFloat_Check(v.ptr()) || py::hasattr(v, "__float__")) {
    const double x = PyFloat_AsDouble(v.ptr());
    if (x == -1.0 && PyErr_Occurred()) throw py::error_already_set();
    if (!std::isfinite(x)) fail(file, path, "expected a finite number, got " + std::string(py::repr(v)));
    return x;
  }
  if (PyDict_Check(v.ptr())) {
    json out = json::object();
    for (const auto& [key, value] : py::reinterpret_borrow<py::dict>(v)) {
      if (!PyUnicode_Check(key.ptr()))
        fail(file, path, "keys must be strings, got " + std::string(Py_TYPE(key.ptr())->tp_name) + " " +
                             std::string(py::repr(key)));
      const std::string k = key.cast<std::string>();
      out[k] = json_from_python(value, file, child(path, k));
    }
    return out;
  }
  if (PyList_Check(v.ptr()) || PyTuple_Check(v.ptr())) {
    json out = json::array();
    size_t i = 0;
    for (const py::handle item : v) {
      out.push_back(json_from_python(item, file, child(path, i)));
      ++i;
    }
    return out;
  }
  fail(file, path, std::string("expected a JSON value (dict, list, str, number, bool or None), got ") +
                       Py_TYPE(v.ptr())->tp_name);
}

py::object python_from_json(const json& j) { return py::module_::import("json").attr("loads")(j.dump()); }

// "fingers[0].grip", "material.young": the JSON paths of the error messages, as keys.
struct Step {
  std::string key;  // an object's key, or "" for an array index
  size_t index = 0;
};

std::vector<Step> parse_key(const std::string& key, const std::string& file) {
  std::vector<Step> steps;
  size_t i = 0;
  const auto bad = [&] { fail(file, "", "key \"" + key + "\": expected a JSON path such as material.young or fingers[0].grip"); };
  while (i < key.size()) {
    const size_t end = key.find_first_of(".[", i);
    const std::string name = key.substr(i, end == std::string::npos ? std::string::npos : end - i);
    if (name.empty()) bad();
    steps.push_back({name, 0});
    i = end == std::string::npos ? key.size() : end;
    while (i < key.size() && key[i] == '[') {
      const size_t close = key.find(']', i);
      if (close == std::string::npos || close == i + 1) bad();
      const std::string digits = key.substr(i + 1, close - i - 1);
      if (digits.find_first_not_of("0123456789") != std::string::npos || digits.size() > 9) bad();
      steps.push_back({"", static_cast<size_t>(std::stoul(digits))});
      i = close + 1;
    }
    if (i < key.size()) {
      if (key[i] != '.' || i + 1 == key.size()) bad();
      ++i;
    }
  }
  if (steps.empty()) bad();
  return steps;
}

// The value at `key`, or null when the document has none there.
const json* find_at(const json& doc, const std::vector<Step>& steps) {
  const json* node = &doc;
  for (const Step& s : steps) {
    if (!s.key.empty()) {
      if (!node->is_object() || !node->contains(s.key)) return nullptr;
      node = &(*node)[s.key];
    } else {
      if (!node->is_array() || s.index >= node->size()) return nullptr;
      node = &(*node)[s.index];
    }
  }
  return node;
}

// Writes `value` at `key`, creating objects on the way as `papertear --set` does; an array entry must exist.
void set_at(json& doc, const std::vector<Step>& steps, json value, const std::string& file) {
  json* node = &doc;
  std::string path;
  for (size_t i = 0; i < steps.size(); ++i) {
    const Step& s = steps[i];
    const bool last = i + 1 == steps.size();
    if (!s.key.empty()) {
      if (node->is_null()) *node = json::object();
      if (!node->is_object()) fail(file, path, "not an object, cannot hold \"" + s.key + "\"");
      path = child(path, s.key);
      node = &(*node)[s.key];
    } else {
      if (!node->is_array() || s.index >= node->size())
        fail(file, child(path, s.index),
             node->is_array() ? "no such entry (" + path + " has " + std::to_string(node->size()) + ")" : "not an array");
      path = child(path, s.index);
      node = &(*node)[s.index];
    }
    if (last) *node = std::move(value);
  }
}

// An outline and a preset exclude each other: writing one removes the other.
void drop_other_sheet_shape(json& doc, const std::vector<Step>& steps) {
  if (steps.size() != 2 || steps[0].key != "sheet" || !doc.contains("sheet") || !doc["sheet"].is_object()) return;
  if (steps[1].key == "outline") doc["sheet"].erase("preset");
  if (steps[1].key == "preset") doc["sheet"].erase("outline");
}

// The engine's reading of `doc`, the messages naming `path` (the scenario's file, "" for <scenario>).
pt::Scenario read_document(const json& doc, const std::string& path) {
  pt::Scenario s = pt::parse_scenario_in_code(doc.dump(), path);
  s.path = path;
  return s;
}

void set_value(pt::Scenario& s, const std::string& key, py::handle value) {
  const std::vector<Step> steps = parse_key(key, s.path);
  json doc = scenario_document(s);
  set_at(doc, steps, json_from_python(value, s.path, key), s.path);
  drop_other_sheet_shape(doc, steps);
  s = read_document(doc, s.path);  // only once it is valid: a refused value leaves `s` as it was
}

py::object get_value(const pt::Scenario& s, const std::string& key) {
  const json doc = scenario_document(s);
  const json* v = find_at(doc, parse_key(key, s.path));
  if (v == nullptr) throw py::key_error(key);
  return python_from_json(*v);
}

// Nested dicts merge into the document's objects; other values replace.
void merge_into(json& doc, const json& changes) {
  for (auto it = changes.begin(); it != changes.end(); ++it) {
    if (it.value().is_object() && doc.contains(it.key()) && doc[it.key()].is_object())
      merge_into(doc[it.key()], it.value());
    else
      doc[it.key()] = it.value();
  }
}

// A section of the document (sheet, material, detail, sim, tearing, fingers[i]) as attributes:
// `scenario.material.young = 5e9` is `scenario.set("material.young", 5e9)`.
struct Section {
  py::object scenario;  // the papertear.Scenario it edits
  std::string prefix;
};

std::string finger_path(const pt::Scenario& s, py::handle finger) {
  if (PyUnicode_Check(finger.ptr())) {
    const std::string name = finger.cast<std::string>();
    for (size_t i = 0; i < s.fingers.size(); ++i)
      if (s.fingers[i].name == name) return child("fingers", i);
    throw py::key_error("no finger named \"" + name + "\"");
  }
  const int64_t n = static_cast<int64_t>(s.fingers.size());
  if (PyBool_Check(finger.ptr()) || !PyIndex_Check(finger.ptr()))
    throw py::type_error("finger must be a name or an index, got " + std::string(Py_TYPE(finger.ptr())->tp_name));
  const int64_t i = integer_arg(finger, "finger", std::numeric_limits<int64_t>::min(), std::numeric_limits<int64_t>::max());
  if (i < -n || i >= n)
    throw py::index_error("no finger " + std::to_string(i) +
                          (n == 0 ? std::string(" (the scenario has no fingers)")
                                  : " (the scenario has fingers 0 to " + std::to_string(n - 1) + ")"));
  return child("fingers", static_cast<size_t>(i < 0 ? i + n : i));
}

// A property reading the struct and writing through the document at `key`.
template <typename Get>
void property(py::class_<pt::Scenario>& c, const char* name, const char* key, Get get, const char* doc) {
  c.def_property(
      name, get, [key](pt::Scenario& s, py::handle v) { set_value(s, key, v); }, doc);
}

}  // namespace

void bind_scenario(py::module_& m) {
  py::class_<Section>(m, "ScenarioSection",
                      "A section of a Scenario's document as attributes (scenario.material.young = 5e9); every "
                      "change is validated as a file's.")
      .def("__getattr__",
           [](const Section& sec, const std::string& name) {
             const pt::Scenario& s = sec.scenario.cast<const pt::Scenario&>();
             const json doc = scenario_document(s);
             const json* v = find_at(doc, parse_key(child(sec.prefix, name), s.path));
             if (v == nullptr) throw py::attribute_error(sec.prefix + " has no key \"" + name + "\"");
             return python_from_json(*v);
           })
      .def("__setattr__",
           [](const Section& sec, const std::string& name, py::handle value) {
             set_value(sec.scenario.cast<pt::Scenario&>(), child(sec.prefix, name), value);
           })
      .def("__dir__",
           [](const Section& sec) {
             const pt::Scenario& s = sec.scenario.cast<const pt::Scenario&>();
             const json doc = scenario_document(s);
             std::vector<std::string> keys;
             if (const json* v = find_at(doc, parse_key(sec.prefix, s.path)); v && v->is_object())
               for (auto it = v->begin(); it != v->end(); ++it) keys.push_back(it.key());
             return keys;
           })
      .def("to_dict",
           [](const Section& sec) {
             const pt::Scenario& s = sec.scenario.cast<const pt::Scenario&>();
             return get_value(s, sec.prefix);
           })
      .def("__repr__", [](const Section& sec) {
        const pt::Scenario& s = sec.scenario.cast<const pt::Scenario&>();
        return sec.prefix + " " + std::string(py::repr(get_value(s, sec.prefix)));
      });

  py::class_<pt::Scenario> c(m, "Scenario",
                             "A scenario (docs/scenario-format.md). Scenario(preset) builds one in code; every value "
                             "set is written into its JSON document and read by the engine's parser, so it is "
                             "validated as a file's (InputError, the scenario unchanged).");
  c.def(py::init([](py::handle preset) {
          if (!PyUnicode_Check(preset.ptr()))
            throw py::type_error("preset must be a str such as \"A4\", got " + std::string(Py_TYPE(preset.ptr())->tp_name));
          json doc;
          doc["sheet"]["preset"] = preset.cast<std::string>();
          return read_document(doc, "");
        }),
        "preset"_a = "A4",
        "The defaults of a scenario file {} on the preset sheet (\"A3\" to \"A6\"), no fingers (add_finger).");
  c.def_static(
      "from_dict",
      [](py::handle d, const std::string& path_for_messages) {
        if (!PyDict_Check(d.ptr()))
          throw py::type_error("from_dict takes a dict, got " + std::string(Py_TYPE(d.ptr())->tp_name));
        return read_document(json_from_python(d, path_for_messages, ""), path_for_messages);
      },
      "d"_a, "path_for_messages"_a = "",
      "A scenario from a dict shaped as a scenario file (unknown keys, wrong types and values are InputError "
      "naming the JSON path, as in a file); fingers may be left out.");
  c.def("to_dict", [](const pt::Scenario& s) { return python_from_json(scenario_document(s)); },
        "The scenario file it is, as a dict, every key written (from_dict reads it back).");
  c.def(
      "to_json", [](const pt::Scenario& s, int indent) { return scenario_document(s).dump(indent) + "\n"; },
      "indent"_a = 2, "The scenario file it is (papertear check / run read it; with no fingers they refuse it).");
  c.def("get", &get_value, "key"_a, "The value at a JSON path: \"material.young\", \"fingers[0].grip\".");
  c.def("set", &set_value, "key"_a, "value"_a,
        "Write a value at a JSON path (as papertear --set KEY=VALUE); InputError leaves the scenario unchanged.");
  c.def(
      "update",
      [](pt::Scenario& s, py::handle changes) {
        if (!PyDict_Check(changes.ptr()))
          throw py::type_error("update takes a dict, got " + std::string(Py_TYPE(changes.ptr())->tp_name));
        json doc = scenario_document(s);
        const json patch = json_from_python(changes, s.path, "");
        merge_into(doc, patch);
        if (patch.contains("sheet") && patch["sheet"].is_object()) {
          if (patch["sheet"].contains("outline") && !patch["sheet"].contains("preset")) doc["sheet"].erase("preset");
          if (patch["sheet"].contains("preset") && !patch["sheet"].contains("outline")) doc["sheet"].erase("outline");
        }
        s = read_document(doc, s.path);
      },
      "changes"_a,
      "Several values at once, a nested dict merged into the document ({\"sim\": {\"frames\": 60, "
      "\"relaxation\": \"substep\"}}): all or none.");
  c.def("validate", &pt::validate_scenario, "Raises InputError when the scenario is invalid (it is kept valid).");
  c.def("copy", [](const pt::Scenario& s) { return s; });
  c.def("__copy__", [](const pt::Scenario& s) { return s; });
  c.def("__deepcopy__", [](const pt::Scenario& s, py::handle) { return s; }, "memo"_a);
  c.def("__eq__", [](const pt::Scenario& a, py::handle b) {
    return py::isinstance<pt::Scenario>(b) && scenario_document(a) == scenario_document(b.cast<const pt::Scenario&>());
  });
  c.def("__repr__", [](const pt::Scenario& s) { return "<papertear.Scenario '" + s.name + "'>"; });
  c.def_readonly("path", &pt::Scenario::path, "The file it came from (\"\" when built in code: messages say <scenario>).");

  // Sections as attributes.
  for (const char* section : {"sheet", "material", "detail", "sim", "tearing"}) {
    c.def_property_readonly(
        section, [section](py::object self) { return Section{self, section}; },
        (std::string("The \"") + section + "\" object: scenario." + section + ".KEY reads and writes it.").c_str());
  }
  c.def(
      "finger", [](py::object self, py::handle finger) { return Section{self, finger_path(self.cast<const pt::Scenario&>(), finger)}; },
      "finger"_a, "A finger by name or index as attributes: scenario.finger(\"A\").grip = 20.");

  // The values most often varied, by name.
  property(c, "name", "name", [](const pt::Scenario& s) { return s.name; }, "Names the output directory out/<name>.");
  property(c, "description", "description", [](const pt::Scenario& s) { return s.description; }, "Free text.");
  property(c, "preset", "sheet.preset", [](const pt::Scenario& s) { return s.preset; },
           "\"A3\" to \"A6\", or \"\" when the sheet has an outline; setting it replaces the outline.");
  c.def_property(
      "outline",
      [](const pt::Scenario& s) {
        py::list out;
        for (const pt::Vec2& p : s.outline) out.append(py::make_tuple(p.x(), p.y()));
        return out;
      },
      [](pt::Scenario& s, py::handle v) { set_value(s, "sheet.outline", v); },
      "The sheet's outline [(u, v), ...], m, counter-clockwise (a preset's too); setting it replaces the preset.");
  c.def_property(
      "sheet_size",
      [](const pt::Scenario& s) {
        double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
        for (const pt::Vec2& p : s.outline)
          for (int k = 0; k < 2; ++k) lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
        return s.outline.empty() ? py::make_tuple(0.0, 0.0) : py::make_tuple(hi[0] - lo[0], hi[1] - lo[1]);
      },
      [](pt::Scenario& s, py::handle v) {
        const py::sequence wh = py::reinterpret_borrow<py::object>(v);
        if (!PySequence_Check(v.ptr()) || PyUnicode_Check(v.ptr()) || py::len(wh) != 2)
          throw py::type_error("sheet_size must be (width, height) in m");
        const double w = number_arg(wh[0], "sheet_size width"), h = number_arg(wh[1], "sheet_size height");
        set_value(s, "sheet.outline",
                  py::make_tuple(py::make_tuple(0.0, 0.0), py::make_tuple(w, 0.0), py::make_tuple(w, h),
                                 py::make_tuple(0.0, h)));
      },
      "(width, height), m: the outline's box; setting it makes the sheet that rectangle at the origin.");
  property(c, "triangles", "sheet.triangles", [](const pt::Scenario& s) { return s.triangles; }, "The mesh's target.");
  property(c, "mesh_seed", "sheet.mesh_seed", [](const pt::Scenario& s) { return s.mesh_seed; }, "");
  property(c, "mesh_rotation_deg", "sheet.mesh_rotation_deg", [](const pt::Scenario& s) { return s.mesh_rotation_deg; }, "");
  property(c, "hand_lines", "sheet.hand_lines", [](const pt::Scenario& s) { return s.hand_lines; },
           "Mesh the line between a hand's consecutive fingers as edges.");
  property(c, "fiber_seed", "material.fiber_seed", [](const pt::Scenario& s) { return s.material.fiber_seed; }, "");
  property(c, "frames", "sim.frames", [](const pt::Scenario& s) { return s.sim.frames; }, "");
  property(c, "fps", "sim.fps", [](const pt::Scenario& s) { return s.sim.fps; }, "Frames per second.");
  c.def_property(
      "dt", [](const pt::Scenario& s) { return 1.0 / s.sim.fps; },
      [](pt::Scenario& s, py::handle v) {
        const double dt = number_arg(v, "dt");
        if (!(dt > 0)) throw py::value_error("dt must be a positive number of seconds, got " + std::string(py::repr(v)));
        set_value(s, "sim.fps", py::float_(1.0 / dt));
      },
      "A frame's duration, s: 1 / sim.fps (setting it sets sim.fps).");
  property(c, "substeps", "sim.substeps", [](const pt::Scenario& s) { return s.sim.substeps; }, "Substeps per frame.");
  property(c, "iterations", "sim.iterations", [](const pt::Scenario& s) { return s.sim.iterations; }, "");
  property(c, "solver", "sim.solver", [](const pt::Scenario& s) { return s.sim.solver; }, "\"implicit\" or \"projective\".");
  property(c, "relaxation", "sim.relaxation", [](const pt::Scenario& s) { return s.sim.relaxation; },
           "sim.relaxation: \"substep\", \"next_frame\" or \"patch\".");
  property(c, "relaxation_radius", "sim.relaxation_radius", [](const pt::Scenario& s) { return s.sim.relaxation_radius; },
           "sim.relaxation_radius, m");
  property(c, "step_splits", "sim.step_splits", [](const pt::Scenario& s) { return s.sim.step_splits; },
           "sim.step_splits: how many times a substep that jumped past the strain limit may be halved (0: off).");
  property(c, "split_strain_jump", "sim.split_strain_jump", [](const pt::Scenario& s) { return s.sim.split_strain_jump; },
           "sim.split_strain_jump: the strain a substep may add past the strain limit before it is split.");
  c.def_property(
      "self_contact",
      [](const pt::Scenario& s) -> py::object {
        if (!s.sim.self_contact.on) return py::bool_(false);
        return python_from_json(scenario_document(s)["sim"]["self_contact"]);
      },
      [](pt::Scenario& s, py::handle v) { set_value(s, "sim.self_contact", v); },
      "sim.self_contact: False (off), True (the defaults) or {\"gap\": m, \"friction\": mu}; reads False or the settings.");
  c.def_property_readonly(
      "fingers", [](const pt::Scenario& s) { return python_from_json(scenario_document(s)["fingers"]); },
      "The fingers as the file has them: name, at, keys, interpolation (absent: linear), attach, release (absent: "
      "never), grip, pad (absent: 0).");
  c.def(
      "add_finger",
      [](pt::Scenario& s, py::handle name, py::handle at, py::handle keys, py::handle attach, py::handle release,
         py::handle grip, py::handle pad, py::handle interpolation) {
        py::dict finger("name"_a = name, "at"_a = at, "keys"_a = keys, "attach"_a = attach, "grip"_a = grip,
                        "pad"_a = pad, "interpolation"_a = interpolation);
        if (!release.is_none()) finger["release"] = release;
        json doc = scenario_document(s);
        const std::string path = child("fingers", doc["fingers"].size());
        doc["fingers"].push_back(json_from_python(finger, s.path, path));
        s = read_document(doc, s.path);
      },
      "name"_a, "at"_a, "keys"_a = py::list(), "attach"_a = 0.0, "release"_a = py::none(), "grip"_a = 15.0,
      "pad"_a = 0.0, "interpolation"_a = "linear",
      "Add a finger holding pattern point at = (u, v) (a disc of radius pad, m, if pad > 0); keys [(t, (x, y, "
      "z)), ...] joined \"linear\" or \"smooth\"; InputError as in a file.");
  c.def(
      "remove_finger",
      [](pt::Scenario& s, py::handle finger) {
        const std::string path = finger_path(s, finger);
        json doc = scenario_document(s);
        doc["fingers"].erase(static_cast<size_t>(std::stoul(path.substr(path.find('[') + 1))));
        s = read_document(doc, s.path);
      },
      "finger"_a, "Remove a finger by name or index (InputError if a hand still names it).");
}

}  // namespace papertear_py
