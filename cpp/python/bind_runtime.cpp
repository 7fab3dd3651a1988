// What the core runs on: its threads, the OpenCV it was built against, its working
// memory; and the private submodule _hooks (liff/hooks.hpp) of liff's tests and benchmarks.
#include <opencv2/core.hpp>
#include <string>

#include <pybind11/stl.h>

#include <liff/hooks.hpp>
#include <liff/liff.hpp>

#include "bindings.hpp"

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
}

void BindVersion(py::module_& m) {
  m.def(
      "opencvVersion", [] { return std::string(CV_VERSION); },
      "Version of the system OpenCV the core was built against.");
}

void BindHooks(py::module_& m) {
  py::module_ hooks = m.def_submodule(
      "_hooks", "liff's own test and benchmark hooks (liff/hooks.hpp): not API, may change.");
  hooks.def("set_profiling", &hooks::setProfiling, "enabled"_a,
            "Turns per-stage timing on or off (off by default).");
  hooks.def("reset_profile", &hooks::resetProfile,
            "Zeroes the stage timers and forgets the parallel loops recorded.");
  hooks.def(
      "stage_seconds",
      [](bool inLoops) {
        const std::vector<std::string> names = hooks::stageNames();
        const std::vector<double> seconds = hooks::stageSeconds(inLoops);
        py::dict d;
        for (size_t i = 0; i < names.size(); ++i) d[names[i].c_str()] = seconds[i];
        return d;
      },
      "in_loops"_a = false,
      "Seconds per stage (dict), summed over threads, since the last reset (with in_loops,\n"
      "only the part inside profiled parallel loops).");
  hooks.def("set_slice_batch", &hooks::setSliceBatch, "batch"_a,
            "Builds `batch` slices at once whatever the thread count (0: one per thread, the\n"
            "default), to profile on one thread the loops of a `batch`-thread call.");
  hooks.def(
      "parallel_loops",
      [] {
        py::list loops;
        for (const hooks::ParallelLoop& loop : hooks::parallelLoops())
          loops.append(py::make_tuple(loop.name, loop.wall, loop.tasks));
        return loops;
      },
      "(name, wall seconds, [seconds of each task]) of every outermost parallel loop since\n"
      "the last reset, in call order (each index a task while profiling).");
  hooks.def("working_memory_peak", &hooks::workingMemoryPeakBytes, "reset"_a = false,
            "The most bytes of the core's buffers (a page or more) in use and kept at once\n"
            "since the last reset; reset=True starts again from now.");
}

}  // namespace python
}  // namespace liff
