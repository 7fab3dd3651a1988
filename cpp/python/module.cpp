// liff._core: the compiled part of the liff package.
#include "arrays.hpp"

#include <liff/liff.hpp>

namespace liff {
namespace python {
void BindLiFF(py::module_& m);
}  // namespace python
}  // namespace liff

PYBIND11_MODULE(_core, m) {
  namespace py = pybind11;
  using namespace pybind11::literals;
  m.doc() = "Compiled core of liff (C++17, linked to the system OpenCV).";
  m.attr("SLOPE_SCALE") = liff::kSlopeScale;

  // Argument errors from the core become ValueError, a light field too large for the
  // memory limit MemoryError; anything else RuntimeError.
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const cv::Exception& e) {
      const std::string message = e.err.empty() ? std::string(e.what()) : e.err;
      if (e.code == cv::Error::StsBadArg || e.code == cv::Error::StsBadSize ||
          e.code == cv::Error::StsOutOfRange || e.code == cv::Error::StsParseError)
        PyErr_SetString(PyExc_ValueError, message.c_str());
      else if (e.code == cv::Error::StsNoMem)
        PyErr_SetString(PyExc_MemoryError, message.c_str());
      else
        PyErr_SetString(PyExc_RuntimeError, e.what());
    }
  });

  liff::python::BindArrays(m);
  liff::python::BindLiFF(m);
}
