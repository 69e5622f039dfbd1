// papertear.run_batch: `papertear batch` from Python (docs/batch.md). The same steps as the command line's
// one-process batch (apps/papertear.cpp, batch_command): every sheet's scenario checked and the memory of
// the sheets at once estimated before any runs, then engine/batch.hpp's run_batch, whose hashes do not
// depend on the thread count; batch.csv and batch.json written when `out` is given.
#include "python/arguments.hpp"

#include <pybind11/stl.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

namespace papertear_py {

namespace {

namespace fs = std::filesystem;
using namespace pybind11::literals;

// "KEY=FROM:TO" as --vary takes it, or (key, from, to). The engine's parser checks both, its messages
// naming "vary" rather than the command line's "--vary".
pt::Variation variation_arg(py::handle v, size_t i) {
  const std::string name = "vary[" + std::to_string(i) + "]";
  std::string text;
  if (PyUnicode_Check(v.ptr())) {
    text = v.cast<std::string>();
  } else if (PyTuple_Check(v.ptr()) || PyList_Check(v.ptr())) {
    const py::sequence t = py::reinterpret_borrow<py::sequence>(v);
    if (py::len(t) != 3 || !PyUnicode_Check(t[0].ptr()))
      throw py::type_error(name + " must be \"KEY=FROM:TO\" or (key, from, to)");
    char range[64];
    std::snprintf(range, sizeof range, "%.17g:%.17g", number_arg(t[1], name + " from"), number_arg(t[2], name + " to"));
    text = t[0].cast<std::string>() + "=" + range;
  } else {
    throw py::type_error(name + " must be \"KEY=FROM:TO\" or (key, from, to), got " + Py_TYPE(v.ptr())->tp_name);
  }
  try {
    return pt::parse_variation(text);
  } catch (const pt::InputError& e) {
    const std::string what = e.what();
    throw pt::InputError(what.rfind("--vary ", 0) == 0 ? "vary " + what.substr(7) : what);
  }
}

py::dict outcome_dict(const pt::SheetOutcome& o, const std::vector<pt::Variation>& vary) {
  py::dict values;
  for (size_t k = 0; k < vary.size() && k < o.varied.size(); ++k) values[py::str(vary[k].key)] = o.varied[k];
  return py::dict("index"_a = o.index, "fiber_seed"_a = o.fiber_seed, "mesh_seed"_a = o.mesh_seed,
                  "varied"_a = o.varied, "values"_a = values, "triangles"_a = o.triangles,
                  "tear_length"_a = o.tear_length, "tears"_a = o.tears, "pieces"_a = o.pieces,
                  "max_finger_force"_a = o.max_finger_force, "frame_ms"_a = o.frame_ms, "hash"_a = o.hash,
                  "status"_a = o.status);
}

py::dict run_batch_from_python(py::handle scenario, py::handle sheets, py::handle vary, py::handle fixed_seeds,
                               py::handle threads, py::handle frames, py::handle settings, py::handle out) {
  std::vector<std::string> set;
  if (!settings.is_none()) {
    if (PyUnicode_Check(settings.ptr()) || !PySequence_Check(settings.ptr()))
      throw py::type_error("settings must be a list of \"KEY=VALUE\" strings");
    for (const py::handle s : settings) {
      if (!PyUnicode_Check(s.ptr())) throw py::type_error("settings must be a list of \"KEY=VALUE\" strings");
      set.push_back(s.cast<std::string>());
    }
  }
  pt::Scenario base;
  if (py::isinstance<pt::Scenario>(scenario)) {
    if (!set.empty()) throw py::value_error("settings apply to a scenario file; set the Scenario's values instead");
    base = scenario.cast<pt::Scenario>();
  } else {
    base = pt::load_scenario(path_arg(scenario, "scenario"), set);
  }
  pt::BatchOptions options;
  options.sheets = static_cast<int32_t>(integer_arg(sheets, "sheets", 1, 1'000'000));
  options.threads = threads_arg(threads);
  options.frames = frames.is_none() ? -1 : static_cast<int32_t>(integer_arg(frames, "frames", 1, 10'000'000));
  options.fixed_seeds = bool_arg(fixed_seeds, "fixed_seeds");
  if (PyUnicode_Check(vary.ptr()) || !PySequence_Check(vary.ptr()))
    throw py::type_error("vary must be a list of \"KEY=FROM:TO\" or (key, from, to)");
  size_t i = 0;
  for (const py::handle v : vary) options.vary.push_back(variation_arg(v, i++));

  int32_t largest = 0;
  for (int32_t s = 0; s < options.sheets; ++s) {
    pt::validate_batch_sheet(base, options, s);
    largest = std::max(largest, pt::batch_sheet_scenario(base, options, s).triangles);
  }
  pt::check_batch_memory(std::min(options.sheets, options.threads), largest, "threads");
  fs::path dir;
  if (!out.is_none()) {
    dir = path_arg(out, "out");
    std::error_code ec;
    if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
      throw py::value_error("out " + dir.string() + ": exists and is not a directory");
    fs::create_directories(dir, ec);
    if (ec) {
      PyErr_SetString(PyExc_OSError, ("out " + dir.string() + ": cannot create the directory: " + ec.message()).c_str());
      throw py::error_already_set();
    }
  }

  pt::BatchResult result;
  {
    py::gil_scoped_release release;
    result = pt::run_batch(base, options);
  }
  py::list written;
  if (!out.is_none()) {
    const fs::path csv = dir / "batch.csv", json = dir / "batch.json";
    try {
      pt::write_batch_csv(result, csv.string());
      pt::write_batch_json(result, base.name, json.string());
    } catch (const std::exception& e) {
      raise_os_error(e.what());
    }
    written.append(json.string());
    written.append(csv.string());
  }
  py::list vary_out, hashes, outcomes;
  for (const pt::Variation& v : result.vary) vary_out.append(py::dict("key"_a = v.key, "from"_a = v.from, "to"_a = v.to));
  for (const pt::SheetOutcome& o : result.outcomes) {
    hashes.append(o.hash);
    outcomes.append(outcome_dict(o, result.vary));
  }
  return py::dict("scenario"_a = base.name, "sheets"_a = result.sheets, "threads"_a = result.threads,
                  "frames"_a = result.frames, "vary"_a = vary_out, "fixed_seeds"_a = result.fixed_seeds,
                  "wall_s"_a = result.wall_s, "sheet_frames_per_s"_a = result.sheet_frames_per_s, "hashes"_a = hashes,
                  "outcomes"_a = outcomes, "written"_a = written);
}

}  // namespace

void bind_batch(py::module_& m) {
  m.def("run_batch", &run_batch_from_python, "scenario"_a, "sheets"_a, py::kw_only(), "vary"_a = py::list(),
        "fixed_seeds"_a = false, "threads"_a = 2, "frames"_a = py::none(), "settings"_a = py::none(),
        "out"_a = py::none(),
        "papertear batch SCENARIO --sheets N [--vary KEY=FROM:TO]... [--fixed-seeds] [--threads N] [--frames N] "
        "[--set KEY=VALUE]... [--out DIR]: `sheets` variations of a Scenario or a scenario file run in parallel. "
        "Returns batch.json's scenario, sheets, threads, frames, vary, fixed_seeds, wall_s, sheet_frames_per_s, "
        "hashes and outcomes (per sheet: index, seeds, varied, values, triangles, tear_length, tears, pieces, "
        "max_finger_force, frame_ms, hash, status), and `written` (the files). With `out`, writes DIR/batch.json "
        "and DIR/batch.csv as the command line does. InputError (a ValueError) for a bad scenario, sheet or vary.");
}

}  // namespace papertear_py
