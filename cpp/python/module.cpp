// liff._core: the compiled part of the liff package.
#include <liff/liff.hpp>
#include <string>

#include "bindings.hpp"

PYBIND11_MODULE(_core, m) {
  m.doc() = "Compiled core of liff (C++17, linked to the system OpenCV).";
  m.attr("SLOPE_SCALE") = liff::kSlopeScale;
  m.attr("RANGE_END_SHARE") = liff::kRangeEndShare;
  m.attr("SMALL_REACH") = liff::kSmallReach;

  // Argument errors from the core become ValueError, a light field too large for the
  // memory limit MemoryError; anything else RuntimeError.
  pybind11::register_exception_translator([](std::exception_ptr p) {
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

  liff::python::BindParameters(m);
  liff::python::BindLiFF(m);
  liff::python::BindThreads(m);
  liff::python::BindVersion(m);
  liff::python::BindAllocation(m);
  liff::python::BindHooks(m);
}
