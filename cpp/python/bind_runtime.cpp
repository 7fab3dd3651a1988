// What the core runs on: its threads, the OpenCV it was built against, and the
// stage timers benchmarks read.
#include <opencv2/core.hpp>
#include <string>

#include "bindings.hpp"
#include "light_field.hpp"
#include "profile.hpp"

namespace liff {
namespace python {

using namespace pybind11::literals;

void BindThreads(py::module_& m) {
  m.def(
      "setNumThreads", [](int n) { cv::setNumThreads(n); }, "nthreads"_a,
      "Sets the number of threads of LiFF's core (the system OpenCV's parallel_for_).\n\n"
      "cv2.setNumThreads does not reach it. Results do not depend on the count. A negative\n"
      "value restores the default; 0 or 1 runs serially.");
  m.def("getNumThreads", &cv::getNumThreads,
        "Number of threads LiFF's core uses (see setNumThreads).");
}

void BindAllocation(py::module_& m) {
  m.def("_set_view_by_view_allocation", &detail::setViewByViewAllocation, "enabled"_a,
        "liff._allocator only: allocate a converted light field view by view (for a\n"
        "process that keeps freed memory) or as one buffer (the default); returns the\n"
        "previous setting.");
}

void BindVersion(py::module_& m) {
  m.def(
      "opencvVersion", [] { return std::string(CV_VERSION); },
      "Version of the system OpenCV the core was built against.");
}

void BindProfiling(py::module_& m) {
  m.def("_set_profiling", &detail::setProfiling, "enabled"_a,
        "Benchmarks only: turn per-stage timing on or off (off by default).");
  m.def("_reset_profile", &detail::resetProfile, "Benchmarks only: zero the stage timers.");
  m.def(
      "_stage_seconds",
      [] {
        const auto s = detail::stageSeconds();
        py::dict d;
        const char* names[] = {"focal_stack", "scale_space", "extrema", "refinement",
                               "descriptors"};
        for (int i = 0; i < detail::kStageCount; ++i) d[names[i]] = s[i];
        return d;
      },
      "Benchmarks only: seconds per stage, summed over threads, since the last reset.");
}

}  // namespace python
}  // namespace liff
