// Python bindings of the engine (issue 8): `import papertear`.
//
// Arrays are numpy VIEWS of the sheet's own arrays (no copy), read-only, kept alive by the Simulation
// object they came from, and they follow stepping. When the topology changes (a tear is cut, a finger is
// attached) rows are inserted or renumbered and a view taken before has the old shape: take the property
// again when `Simulation.topology_version` changes. A view never dangles: the wrapper keeps capacity
// ahead of the engine's growth (the engine only push_backs/resizes, it never reassigns these vectors), and
// when it must grow an array it moves the old storage into a graveyard that lives as long as the
// Simulation, so an old view goes stale but stays readable.
//
// One Simulation may be shared by Python threads: every method holds the simulation's own lock, so calls
// are serialised (step() releases the GIL, not that lock). A thread that must wait for it waits without
// the GIL, so the thread stepping can take the GIL back between frames (signals) and nothing deadlocks.
// Numpy views are outside the lock: reading one while another thread steps sees values of either frame.
// The module's other files: arguments (one-line errors), scenario_bindings (Scenario built in code),
// batch_bindings (run_batch).
#include "engine/papertear.hpp"
#include "engine/simulation_internals.hpp"
#include "engine/texture_export.hpp"
#include "python/arguments.hpp"

#include <nlohmann/json.hpp>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace py = pybind11;
using namespace pybind11::literals;
using namespace papertear_py;

namespace {

// A read-only (rows, cols) view of `data`, owned by `owner` (the Python Simulation).
template <typename T>
py::array view(const T* data, size_t rows, size_t cols, size_t row_stride_bytes, py::handle owner) {
  std::vector<py::ssize_t> shape{static_cast<py::ssize_t>(rows), static_cast<py::ssize_t>(cols)};
  std::vector<py::ssize_t> strides{static_cast<py::ssize_t>(row_stride_bytes),
                                   static_cast<py::ssize_t>(sizeof(T))};
  if (rows == 0) return py::array_t<T>(shape);  // empty: no data pointer to share
  py::array a(py::dtype::of<T>(), shape, strides, data, owner);
  a.attr("setflags")("write"_a = false);
  return a;
}

py::list points(const std::vector<pt::Vec2>& ps) {
  py::list out;
  for (const pt::Vec2& p : ps) out.append(py::make_tuple(p.x(), p.y()));
  return out;
}

py::dict stat(const pt::TimingStat& s) { return py::dict("avg"_a = s.avg(), "max"_a = s.max, "count"_a = s.count); }

// The Python Simulation: the engine plus the storage views may still point to, and the lock that
// serialises the threads using it.
struct PySim {
  std::unique_ptr<pt::Simulation> sim;
  std::mutex mutex;
  std::atomic<std::thread::id> owner{};  // the thread holding `mutex`, to refuse a re-entrant call
  std::vector<std::vector<pt::Vec3>> old_x;
  std::vector<std::vector<pt::Vec2>> old_rest;
  std::vector<std::vector<pt::Tri>> old_tri;
  std::vector<std::vector<int32_t>> old_piece;
  // write_obj(textured=True)'s writer per directory: paper.png once, a carved atlas when carving changed,
  // as `papertear run --obj` writes its frames.
  std::map<std::string, std::unique_ptr<pt::TexturedObjWriter>> obj_writers;

  // Before anything that may add vertices or triangles: at least 2n + 1024 free rows, else grow to
  // 4n + 1024 (amortised; the graveyard is at most about the final size).
  template <typename T>
  static void headroom(std::vector<T>& v, std::vector<std::vector<T>>& graveyard) {
    const size_t n = v.size();
    if (v.capacity() >= 2 * n + 1024) return;
    std::vector<T> bigger;
    bigger.reserve(4 * n + 1024);
    bigger.assign(v.begin(), v.end());
    if (v.capacity() > 0) graveyard.push_back(std::move(v));
    v = std::move(bigger);
  }
  void make_room() {
    pt::Sheet& s = pt::mutable_sheet(*sim);
    headroom(s.verts.x, old_x);
    headroom(s.verts.rest, old_rest);
    headroom(s.tris.tri, old_tri);
    headroom(s.tris.piece, old_piece);
  }
};

PySim& py_of(const py::object& self) { return self.cast<PySim&>(); }

// Holds a simulation's lock for one call. Called with the GIL held; when another thread has the lock it
// waits with the GIL released (that thread may need the GIL to finish). The same thread asking again
// (a signal handler run between frames of its own step()) is refused: waiting would never end.
class SimLock {
 public:
  explicit SimLock(PySim& p) : p_(p), lock_(p.mutex, std::try_to_lock) {
    if (!lock_.owns_lock()) {
      if (p.owner.load() == std::this_thread::get_id())
        throw std::runtime_error("Simulation: called again from inside one of its own calls on this thread "
                                 "(a signal handler during step()?)");
      py::gil_scoped_release release;
      lock_.lock();
    }
    p.owner.store(std::this_thread::get_id());
  }
  ~SimLock() { p_.owner.store(std::thread::id()); }
  SimLock(const SimLock&) = delete;
  SimLock& operator=(const SimLock&) = delete;

 private:
  PySim& p_;
  std::unique_lock<std::mutex> lock_;
};

// A finger index from Python: IndexError, as Python's sequences say it, for one the sheet does not have (not
// wrapped: -1 is no finger, and a large int is not cut to 32 bits).
int32_t finger_index(const PySim& p, int64_t finger, const char* call) {
  const int64_t n = static_cast<int64_t>(p.sim->sheet().fingers.size());
  if (finger < 0 || finger >= n)
    throw py::index_error(std::string(call) + ": no finger " + std::to_string(finger) +
                          (n == 0 ? std::string(" (the sheet has no fingers)")
                                  : " (the sheet has fingers 0 to " + std::to_string(n - 1) + ")"));
  return static_cast<int32_t>(finger);
}

// A writer's call on the flushed simulation, the lock held and the GIL released; a file that cannot be
// written is an OSError with the writer's message.
template <typename Write>
void write_flushed(PySim& p, const Write& write) {
  const SimLock lock(p);
  bool failed = false;
  std::string error;
  {
    py::gil_scoped_release release;
    p.sim->flush();
    try {
      write(*p.sim);
    } catch (const std::exception& e) {
      failed = true;
      error = e.what();
    }
  }
  if (failed) raise_os_error(error);
}

}  // namespace

PYBIND11_MODULE(papertear, m) {
  m.doc() = "papertear: paper torn by fingers (Schreck, Rohmer & Hahmann, Interactive paper tearing, 2017)";
  m.attr("__version__") = pt::version();

  // "<file>: <json path>: <problem>"; both are ValueErrors.
  py::register_exception<pt::InputError>(m, "InputError", PyExc_ValueError);
  py::register_exception<pt::GeometryError>(m, "GeometryError", PyExc_ValueError);

  bind_scenario(m);
  bind_batch(m);

  m.def(
      "load_scenario",
      [](const std::string& path, const std::vector<std::string>& settings) { return pt::load_scenario(path, settings); },
      "path"_a, "settings"_a = std::vector<std::string>{},
      "Load and validate a scenario file, with settings [\"sim.relaxation=patch\", ...] written into its JSON first (as "
      "papertear --set); raises InputError.");
  m.def("parse_scenario", &pt::parse_scenario, "json_text"_a, "path_for_messages"_a = "<string>",
        "Parse and validate scenario JSON text; raises InputError.");

  py::class_<PySim>(m, "Simulation",
                    "One simulated sheet. Threads may share it: its calls take turns (a call waits for the "
                    "one in progress, step(n) included).")
      .def(py::init([](py::handle src, py::handle threads, py::handle check_invariants) {
             pt::EngineOptions options;
             options.threads = threads_arg(threads);
             options.check_invariants = bool_arg(check_invariants, "check_invariants");
             const pt::Scenario scenario = scenario_arg(src, "scenario");
             auto p = std::make_unique<PySim>();
             {
               py::gil_scoped_release release;
               p->sim = std::make_unique<pt::Simulation>(scenario, options);
             }
             p->make_room();
             return p;
           }),
           "scenario"_a, "threads"_a = 2, "check_invariants"_a = false,
           "From a scenario file path or a Scenario. threads: 1 to 1024, capped at the CPUs (a RuntimeWarning "
           "says so; results are the same at any count). Raises InputError / GeometryError.")
      .def(
          "step",
          [](PySim& p, py::handle frames) {
            const auto n = static_cast<int32_t>(integer_arg(frames, "n", 0, 10'000'000));
            const SimLock lock(p);
            for (int32_t i = 0; i < n; ++i) {
              {
                py::gil_scoped_release release;
                p.make_room();
                p.sim->step();
              }
              // Between frames, with the GIL: Ctrl-C raises KeyboardInterrupt here, the sheet whole at
              // the frame just done (the main thread would otherwise see the signal only after all n).
              if (PyErr_CheckSignals() != 0) throw py::error_already_set();
            }
          },
          "n"_a = 1,
          "Advance n frames. A signal (Ctrl-C) stops it between two frames with its exception "
          "(KeyboardInterrupt); `frame` tells how many were done and the simulation can go on.")
      .def(
          "flush",
          [](PySim& p) {
            const SimLock lock(p);
            py::gil_scoped_release release;
            p.sim->flush();
          },
          "Carve the last frame's segments (tears' `detail` complete).")
      .def_property_readonly("frame", [](PySim& p) {
        const SimLock lock(p);
        return p.sim->frame();
      })
      .def_property_readonly("time", [](PySim& p) {
        const SimLock lock(p);
        return p.sim->time();
      })
      .def_property_readonly("threads", [](PySim& p) {
        const SimLock lock(p);
        return p.sim->threads();
      })
      .def_property_readonly("scenario", [](PySim& p) {
        const SimLock lock(p);
        return p.sim->scenario();
      })
      .def_property_readonly(
          "hash",
          [](PySim& p) {
            const SimLock lock(p);
            return p.sim->state_hash();
          },
          "Hex digest of the current state.")
      .def_property_readonly(
          "topology_version",
          [](PySim& p) {
            const SimLock lock(p);
            return p.sim->sheet().topology_version;
          },
          "Changes whenever vertices/triangles are inserted: views taken before are stale.")
      // Views (no copy).
      .def_property_readonly(
          "positions",
          [](py::object self) {
            const SimLock lock(py_of(self));
            const auto& x = py_of(self).sim->sheet().verts.x;
            return view<double>(x.empty() ? nullptr : x.front().data(), x.size(), 3, sizeof(pt::Vec3), self);
          },
          "(n, 3) float64 view of the 3D vertex positions, m.")
      .def_property_readonly(
          "rest",
          [](py::object self) {
            const SimLock lock(py_of(self));
            const auto& r = py_of(self).sim->sheet().verts.rest;
            return view<double>(r.empty() ? nullptr : r.front().data(), r.size(), 2, sizeof(pt::Vec2), self);
          },
          "(n, 2) float64 view of the pattern (u, v) coordinates, m.")
      .def_property_readonly(
          "triangles",
          [](py::object self) {
            const SimLock lock(py_of(self));
            const auto& t = py_of(self).sim->sheet().tris.tri;
            return view<int32_t>(t.empty() ? nullptr : t.front().data(), t.size(), 3, sizeof(pt::Tri), self);
          },
          "(m, 3) int32 view of the triangles' vertex ids.")
      .def_property_readonly(
          "triangle_pieces",
          [](py::object self) {
            const SimLock lock(py_of(self));
            const auto& p = py_of(self).sim->sheet().tris.piece;
            return view<int32_t>(p.data(), p.size(), 1, sizeof(int32_t), self).attr("reshape")(-1);
          },
          "(m,) int32 view: connected piece id of each triangle.")
      .def_property_readonly("pieces", [](PySim& p) {
        const SimLock lock(p);
        return p.sim->sheet().topo.piece_count;
      })
      .def_property_readonly(
          "tears",
          [](PySim& p) {
            const SimLock lock(p);
            const pt::Simulation& s = *p.sim;
            py::list out;
            for (const pt::Tear& t : s.sheet().tears)
              out.append(py::dict("id"_a = t.id, "parent"_a = t.parent < 0 ? py::object(py::none()) : py::int_(t.parent),
                                  "kind"_a = pt::to_string(t.start_kind), "frame"_a = t.start_frame,
                                  "uv"_a = py::make_tuple(t.start_uv.x(), t.start_uv.y()), "tips"_a = points(t.tips),
                                  "detail"_a = points(t.detail), "reached_boundary"_a = t.reached_boundary,
                                  "max_advance_per_frame"_a = t.max_frame_advance));
            return out;
          },
          "Tears: id, parent (None), kind (finger|junction|inward), frame, uv, tips, detail (after flush()).")
      .def_property_readonly(
          "events",
          [](PySim& p) {
            const SimLock lock(p);
            const pt::Simulation& s = *p.sim;
            py::list out;
            for (const pt::TearEvent& e : s.events())
              out.append(py::dict("kind"_a = pt::to_string(e.kind), "tear"_a = e.tear, "frame"_a = e.frame));
            return out;
          },
          "All events so far: kind (tear_started|tear_extended|piece_separated), tear, frame.")
      .def_property_readonly(
          "fingers",
          [](PySim& p) {
            const SimLock lock(p);
            const pt::Simulation& s = *p.sim;
            py::list out;
            for (const pt::Finger& f : s.sheet().fingers)
              out.append(py::dict("name"_a = f.name, "uv"_a = py::make_tuple(f.uv.x(), f.uv.y()), "vertex"_a = f.vertex,
                                  "target"_a = py::make_tuple(f.target.x(), f.target.y(), f.target.z()),
                                  "reaction"_a = py::make_tuple(f.reaction.x(), f.reaction.y(), f.reaction.z()),
                                  "max_force"_a = f.max_force, "released"_a = f.released));
            return out;
          })
      .def_property_readonly(
          "timings",
          [](PySim& p) {
            const SimLock lock(p);
            const pt::Simulation& s = *p.sim;
            const pt::TimingReport& r = s.timings();
            py::dict systems;
            for (size_t i = 0; i < pt::kSystems.size(); ++i) systems[pt::kSystems[i].name] = stat(r.systems[i]);
            return py::dict("physics"_a = stat(r.physics), "geometry"_a = stat(r.geometry), "tearing"_a = stat(r.tearing),
                            "carving"_a = stat(r.carving), "frame"_a = stat(r.frame), "systems"_a = systems);
          },
          "Milliseconds per frame: Table 1 groups and per system, {'avg', 'max', 'count'}.")
      .def(
          "result",
          [](PySim& p) {
            std::string text;
            {
              const SimLock lock(p);
              nlohmann::ordered_json doc;
              pt::build_result_json(*p.sim, doc);
              text = doc.dump();
            }
            return py::module_::import("json").attr("loads")(text);
          },
          "The result.json document (docs/result-format.md) as a dict; call flush() first for complete tear details.")
      // Writers: the files of `papertear run` (docs/result-format.md), each after flush() as the command line
      // writes them (flushing carves now what the next frame would carve beside its physics: the same state).
      .def(
          "write_result",
          [](PySim& p, py::handle path) {
            const std::string file = path_arg(path, "path");
            bool ok = false;
            write_flushed(p, [&](const pt::Simulation& s) { ok = pt::write_result_json(s, file); });
            return ok;
          },
          "path"_a, "Write result.json (as run does); returns True when its status is ok. OSError if it cannot be written.")
      .def(
          "write_svg",
          [](PySim& p, py::handle path) {
            const std::string file = path_arg(path, "path");
            write_flushed(p, [&](const pt::Simulation& s) { pt::write_svg(s, file); });
          },
          "path"_a, "Write the 2D pattern as SVG (run --svg's pattern.svg).")
      .def(
          "write_png",
          [](PySim& p, py::handle path) {
            const std::string file = path_arg(path, "path");
            write_flushed(p, [&](const pt::Simulation& s) {
              pt::write_pattern_png(file, s.scenario().outline, s.sheet().tears, pt::carve_state(s),
                                    pt::detail_params(s), pt::fiber_field(s));
            });
          },
          "path"_a, "Write the pattern at texture resolution with the detailed tears (run --png's pattern.png).")
      .def(
          "write_obj",
          [](PySim& p, py::handle path, py::handle textured) {
            const std::string file = path_arg(path, "path");
            const bool with_texture = bool_arg(textured, "textured");
            const std::filesystem::path target(file);
            if (with_texture && target.extension() != ".obj")
              throw py::value_error("write_obj: a textured frame is <stem>.obj, got " + file);
            write_flushed(p, [&](const pt::Simulation& s) {
              if (!with_texture) {
                pt::write_obj(s, file);
                return;
              }
              const std::filesystem::path dir = target.has_parent_path() ? target.parent_path() : ".";
              const std::string key = std::filesystem::absolute(dir).lexically_normal().string();
              std::unique_ptr<pt::TexturedObjWriter>& writer = p.obj_writers[key];
              if (!writer) writer = std::make_unique<pt::TexturedObjWriter>(dir.string());
              writer->write(s, target.stem().string());
            });
          },
          "path"_a, "textured"_a = false,
          "Write the mesh now as OBJ. textured=True: <stem>.obj + <stem>.mtl with paper.png and the carved atlas "
          "carved_NNNN.png beside them, as run --obj writes each frame (called every frame into one directory it "
          "writes run --obj's frames/: paper.png once, an atlas when the carving changed).")
      // Fingers.
      .def(
          "attach_finger",
          [](PySim& p, py::handle finger_name, py::handle at) {
            const std::string name = string_arg(finger_name, "name");
            const std::vector<double> uv = numbers_arg(at, "uv", 2);
            const SimLock lock(p);
            p.make_room();
            const int32_t i = p.sim->attach_finger(name, pt::Vec2(uv[0], uv[1]));
            if (i < 0) throw py::value_error("attach_finger: (" + std::to_string(uv[0]) + ", " + std::to_string(uv[1]) +
                                             ") is outside the sheet");
            return i;
          },
          "name"_a, "uv"_a, "Put a finger on the pattern point uv now; returns its index (a vertex is inserted).")
      .def(
          "move_finger",
          [](PySim& p, py::handle index, py::handle target) {
            const int64_t finger = integer_arg(index, "finger", INT64_MIN, INT64_MAX);
            const std::vector<double> x = numbers_arg(target, "target", 3, false);
            const SimLock lock(p);
            p.sim->move_finger(finger_index(p, finger, "move_finger"), pt::Vec3(x[0], x[1], x[2]));
          },
          "finger"_a, "target"_a,
          "The finger reaches target (world, m) at the end of the next frame. IndexError for a finger the sheet "
          "does not have; InputError (a ValueError) for a target that is not finite or beyond 1000 m.")
      .def(
          "release_finger",
          [](PySim& p, py::handle index) {
            const int64_t finger = integer_arg(index, "finger", INT64_MIN, INT64_MAX);
            const SimLock lock(p);
            p.sim->release_finger(finger_index(p, finger, "release_finger"));
          },
          "finger"_a, "Let the finger go. IndexError for a finger the sheet does not have.");
}
