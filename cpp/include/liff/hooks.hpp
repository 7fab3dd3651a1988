// Hooks for liff's own tests and benchmarks (benchmarks/core_speed.py, stages.py,
// speed.py, slopes.py, memory.py): not part of the API, and free to change in any release. The
// Python package exposes them as the private submodule liff._core._hooks.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <liff/liff.hpp>

namespace liff {
namespace hooks {

/// Per-stage timing of the core's calls, off by default (one relaxed atomic load per
/// timed block when off). Stages are timed inside the parallel loops: thread-seconds.
void setProfiling(bool enabled);
/// Zeroes the stage timers and forgets the parallel loops recorded.
void resetProfile();
/// The profiled stages' names, in the order of stageSeconds.
std::vector<std::string> stageNames();
/// Thread-seconds per stage since the last reset (the extrema stage excludes the
/// refinement); with `inLoops`, only the part timed inside profiled parallel loops.
std::vector<double> stageSeconds(bool inLoops);

/// Builds `batch` slices at once whatever the thread count (0: one per thread, the
/// default), so that a one-thread profile has the loops of a `batch`-thread call.
void setSliceBatch(int batch);

/// One outermost parallel loop of a profiled call: what it computes, its wall time and
/// each index's time (seconds; each index runs as a task while profiling).
struct ParallelLoop {
  std::string name;
  double wall = 0;
  std::vector<double> tasks;
};
/// The loops profiled since the last reset, in call order.
std::vector<ParallelLoop> parallelLoops();

/// The memory estimate (bytes) the last detect/detectAndCompute/compute call of
/// `detector` checked its limit with (docs/RELIABILITY.md, "Memory"): the total for the
/// slices it built at once (`batch`; 0 and all zero before the first call) and two of its
/// parts.
struct MemoryEstimateParts {
  int batch = 0;
  double total = 0, lightField = 0, survey = 0;
};
MemoryEstimateParts lastMemoryEstimate(const LiFF& detector);

/// The most bytes of the core's buffers (a page or more) in use and kept at once since
/// the last reset; `reset` starts the count again from what is held now.
size_t workingMemoryPeakBytes(bool reset);

/// The slopes (pixels per view step) of the features the automatic range's survey keeps
/// for `lightField` (as detectAndCompute takes it) with `detector`'s parameters,
/// whatever its own range (docs/SLOPES.md).
std::vector<double> surveySlopes(const LiFF& detector, cv::InputArray lightField);

}  // namespace hooks
}  // namespace liff
