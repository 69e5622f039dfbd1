// The module's argument checks and the pieces its files share. A bad argument is one line, as the command
// line's errors are: TypeError for a value of the wrong kind, ValueError (InputError for scenario values)
// for one out of range, never pybind11's several-line "incompatible function arguments" listing.
#pragma once

#include "engine/papertear.hpp"

#include <pybind11/pybind11.h>

#include <cstdint>
#include <string>
#include <vector>

namespace papertear_py {

namespace py = pybind11;

// An int (or an object with __index__, such as numpy's) in [lo, hi]; a bool or a float is a TypeError.
int64_t integer_arg(py::handle value, const std::string& name, int64_t lo, int64_t hi);

// An int or a float, finite.
double number_arg(py::handle value, const std::string& name);

// A sequence of n numbers, e.g. a point (u, v); finite ones unless `finite` is false (the engine then says
// what it refuses).
std::vector<double> numbers_arg(py::handle value, const std::string& name, size_t n, bool finite = true);

// A str.
std::string string_arg(py::handle value, const std::string& name);

// True or False only (1 is not taken for True).
bool bool_arg(py::handle value, const std::string& name);

// A str or os.PathLike naming a file, not empty.
std::string path_arg(py::handle value, const std::string& name);

// A thread count as the command line's --threads takes it: 1 to kMaxThreads, else ValueError; above the
// CPUs it is capped there with a RuntimeWarning in the words of the command line's summary.
int32_t threads_arg(py::handle value);

// A Scenario, or the path of a scenario file (loaded and validated).
pt::Scenario scenario_arg(py::handle value, const std::string& name);

// Raises OSError with a writer's message (a file that cannot be written).
[[noreturn]] void raise_os_error(const std::string& message);

void bind_scenario(py::module_& m);
void bind_batch(py::module_& m);

}  // namespace papertear_py
