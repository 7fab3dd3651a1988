// What the core runs on: its threads, the OpenCV it was built against, and the
// stage timers benchmarks read.
#include <opencv2/core.hpp>
#include <string>

#include <pybind11/stl.h>

#include <liff/liff.hpp>

#include "bindings.hpp"
#include "profile.hpp"
#include "working_memory.hpp"

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
  m.def("releaseWorkingMemory", &releaseWorkingMemory,
        "Frees the working memory the core keeps between calls.\n\n"
        "The core keeps the large buffers a call frees (grey light field, focal slices,\n"
        "scale spaces; Mats of 4 KiB or more of the system OpenCV) for the next call, so\n"
        "a second call takes almost no page faults; in use and kept together stay within\n"
        "twice what the process had in use at once so far. A call's memory limit counts kept memory as available.");
  m.def("keptWorkingMemoryBytes", &keptWorkingMemoryBytes,
        "Bytes the core keeps for reuse now (see releaseWorkingMemory).");
  m.def("setWorkingMemoryReuse", &setWorkingMemoryReuse, "enabled"_a,
        "Turns the keeping of working memory on (the default) or off (what is kept is\n"
        "freed, and nothing is kept from then on).");
  m.def("getWorkingMemoryReuse", &getWorkingMemoryReuse,
        "Whether the core keeps working memory between calls (setWorkingMemoryReuse).");
  m.def("availableMemoryBytes", &availableMemoryBytes,
        "Bytes of physical memory this process can still use, as the detector's default\n"
        "memory limit counts them: MemAvailable, capped by the room under the cgroup's\n"
        "limit, plus the working memory kept for reuse; 0 when unknown (no automatic limit).");
  m.def("_working_memory_peak", &detail::workingMemoryPeakBytes, "reset"_a = false,
        "Tests and benchmarks only: the most bytes of the core's buffers (a page or more) in\n"
        "use and kept at once since the last reset; reset=True starts again from now.");
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
      [](bool inLoops) {
        const auto s = detail::stageSeconds(inLoops);
        py::dict d;
        const char* names[] = {"focal_stack", "scale_space", "extrema", "refinement",
                               "descriptors"};
        for (int i = 0; i < detail::kStageCount; ++i) d[names[i]] = s[i];
        return d;
      },
      "in_loops"_a = false,
      "Benchmarks only: seconds per stage, summed over threads, since the last reset\n"
      "(with in_loops, only the part inside profiled parallel loops).");
  m.def("_set_slice_batch", &detail::setSliceBatchOverride, "batch"_a,
        "Benchmarks only: build `batch` slices at once whatever the thread count (0: one\n"
        "per thread, the default), to profile on one thread the loops of a `batch`-thread call.");
  m.def(
      "_parallel_loops",
      [] {
        py::list loops;
        for (const detail::LoopRecord& loop : detail::loopRecords())
          loops.append(py::make_tuple(loop.name, loop.wall, loop.tasks));
        return loops;
      },
      "Benchmarks only: (name, wall seconds, [seconds of each task]) of every outermost parallel\n"
      "loop since the last reset, in call order (each index a task while profiling).");
}

}  // namespace python
}  // namespace liff
