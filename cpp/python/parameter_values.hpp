// Python values -> the detector's parameters, with errors that name the parameter.
#pragma once

#include <pybind11/pybind11.h>

#include <climits>
#include <liff/parameters.hpp>
#include <string>
#include <type_traits>

namespace liff {
namespace python {

namespace py = pybind11;

/// Python number -> C++ int, double or bool for parameter `name`. pybind11 alone
/// rejects an int beyond C's range as "incompatible function arguments" (TypeError);
/// here such values raise ValueError naming the parameter, and non-numbers TypeError.
template <typename T>
T number(const py::handle& value, const char* name) {
  const std::string what = std::string(name) + " = " + std::string(py::repr(value));
  if constexpr (std::is_same_v<T, bool>) {
    // Python or numpy bools only (pybind11 would raise RuntimeError for others, or
    // take None and 0.5 as booleans).
    const std::string type = py::str(py::type::of(value).attr("__name__"));
    if (!PyBool_Check(value.ptr()) && type != "bool_" && type != "bool")
      throw py::type_error(what + "; expected a bool");
    return PyObject_IsTrue(value.ptr()) == 1;
  } else if constexpr (std::is_same_v<T, int>) {
    if (PyFloat_Check(value.ptr())) throw py::type_error(what + "; expected an integer");
    // True and False are integers to Python, but a bool given for a count, an octave or a
    // type code is a mistake (firstOctave=True would be a silent 1).
    const std::string type = py::str(py::type::of(value).attr("__name__"));
    if (PyBool_Check(value.ptr()) || type == "bool_" || type == "bool")
      throw py::type_error(what + "; expected an integer, not a bool");
    const py::object index = py::reinterpret_steal<py::object>(PyNumber_Index(value.ptr()));
    if (!index) {
      PyErr_Clear();
      throw py::type_error(what + "; expected an integer");
    }
    int overflow = 0;
    const long long v = PyLong_AsLongLongAndOverflow(index.ptr(), &overflow);
    if (overflow != 0 || v < INT_MIN || v > INT_MAX)
      throw py::value_error(what +
                            "; expected an integer in the 32-bit range (and see the "
                            "parameter's own range)");
    return int(v);
  } else {
    const double v = PyFloat_AsDouble(value.ptr());
    if (v == -1.0 && PyErr_Occurred()) {
      const bool overflow = PyErr_ExceptionMatches(PyExc_OverflowError);
      PyErr_Clear();
      if (overflow) throw py::value_error(what + "; expected a value a double can hold");
      throw py::type_error(what + "; expected a number");
    }
    return v;
  }
}

/// The defaults with the keywords of `kwargs` (create()'s names) applied; TypeError
/// for an unknown keyword or a value of the wrong type. Ranges are not checked here.
Parameters parametersFrom(const py::kwargs& kwargs);

}  // namespace python
}  // namespace liff
