#include "python/arguments.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace papertear_py {

namespace {

std::string type_of(py::handle value) { return Py_TYPE(value.ptr())->tp_name; }

std::string shown(py::handle value) {
  std::string text = py::repr(value);
  if (text.size() > 60) text = text.substr(0, 57) + "...";
  for (char& c : text)
    if (c == '\n' || c == '\r') c = ' ';
  return text;
}

}  // namespace

int64_t integer_arg(py::handle value, const std::string& name, int64_t lo, int64_t hi) {
  if (PyBool_Check(value.ptr()) || !PyIndex_Check(value.ptr()))
    throw py::type_error(name + " must be an integer, got " + type_of(value) + " " + shown(value));
  const py::object index = py::reinterpret_steal<py::object>(PyNumber_Index(value.ptr()));
  if (!index) throw py::error_already_set();
  int overflow = 0;
  const long long v = PyLong_AsLongLongAndOverflow(index.ptr(), &overflow);
  if (v == -1 && PyErr_Occurred()) throw py::error_already_set();
  if (overflow != 0 || v < lo || v > hi)
    throw py::value_error(name + " must be " + std::to_string(lo) + " to " + std::to_string(hi) + ", got " +
                          shown(value));
  return v;
}

double number_arg(py::handle value, const std::string& name) {
  if (PyBool_Check(value.ptr()) || !(PyFloat_Check(value.ptr()) || PyLong_Check(value.ptr()) ||
                                      PyIndex_Check(value.ptr()) || py::hasattr(value, "__float__")))
    throw py::type_error(name + " must be a number, got " + type_of(value) + " " + shown(value));
  const double v = PyFloat_AsDouble(value.ptr());
  if (v == -1.0 && PyErr_Occurred()) {
    PyErr_Clear();
    throw py::value_error(name + " must be a finite number, got " + shown(value));
  }
  if (!std::isfinite(v)) throw py::value_error(name + " must be a finite number, got " + shown(value));
  return v;
}

std::vector<double> numbers_arg(py::handle value, const std::string& name, size_t n, bool finite) {
  if (PyUnicode_Check(value.ptr()) || !PySequence_Check(value.ptr()) || py::len(value) != n)
    throw py::type_error(name + " must be a sequence of " + std::to_string(n) + " numbers, got " + type_of(value) + " " +
                         shown(value));
  std::vector<double> out;
  const py::sequence items = py::reinterpret_borrow<py::sequence>(value);
  for (size_t i = 0; i < n; ++i) {
    const py::object item = items[i];
    const std::string item_name = name + "[" + std::to_string(i) + "]";
    if (finite) {
      out.push_back(number_arg(item, item_name));
      continue;
    }
    if (PyBool_Check(item.ptr()) || !(PyFloat_Check(item.ptr()) || PyIndex_Check(item.ptr()) || py::hasattr(item, "__float__")))
      throw py::type_error(item_name + " must be a number, got " + type_of(item) + " " + shown(item));
    const double v = PyFloat_AsDouble(item.ptr());
    if (v == -1.0 && PyErr_Occurred()) {
      PyErr_Clear();
      out.push_back(v > 0 ? HUGE_VAL : -HUGE_VAL);  // an int beyond a double: the engine refuses it as too far
      continue;
    }
    out.push_back(v);
  }
  return out;
}

std::string string_arg(py::handle value, const std::string& name) {
  if (!PyUnicode_Check(value.ptr())) throw py::type_error(name + " must be a str, got " + type_of(value) + " " + shown(value));
  return value.cast<std::string>();
}

bool bool_arg(py::handle value, const std::string& name) {
  if (!PyBool_Check(value.ptr()))
    throw py::type_error(name + " must be True or False, got " + type_of(value) + " " + shown(value));
  return value.ptr() == Py_True;
}

std::string path_arg(py::handle value, const std::string& name) {
  if (!PyUnicode_Check(value.ptr()) && !py::hasattr(value, "__fspath__"))
    throw py::type_error(name + " must be a path (str or os.PathLike), got " + type_of(value) + " " + shown(value));
  const py::object path = py::module_::import("os").attr("fspath")(value);
  if (!PyUnicode_Check(path.ptr()))
    throw py::type_error(name + " must be a path (str or os.PathLike), got " + type_of(path) + " " + shown(path));
  std::string text = path.cast<std::string>();
  if (text.empty()) throw py::value_error(name + " must not be empty");
  if (text.find('\0') != std::string::npos) throw py::value_error(name + " must not contain a NUL character");
  return text;
}

int32_t threads_arg(py::handle value) {
  const auto asked = static_cast<int32_t>(integer_arg(value, "threads", 1, pt::kMaxThreads));
  const pt::ThreadCount threads = pt::usable_threads(asked);
  const std::string note = pt::threads_cap_note(threads, "threads=");
  if (!note.empty() && PyErr_WarnEx(PyExc_RuntimeWarning, note.c_str(), 2) != 0) throw py::error_already_set();
  return threads.used;
}

pt::Scenario scenario_arg(py::handle value, const std::string& name) {
  if (py::isinstance<pt::Scenario>(value)) return value.cast<pt::Scenario>();
  if (!PyUnicode_Check(value.ptr()) && !py::hasattr(value, "__fspath__"))
    throw py::type_error(name + " must be a Scenario or the path of a scenario file, got " + type_of(value));
  return pt::load_scenario(path_arg(value, name));
}

void raise_os_error(const std::string& message) {
  PyErr_SetString(PyExc_OSError, message.c_str());
  throw py::error_already_set();
}

}  // namespace papertear_py
