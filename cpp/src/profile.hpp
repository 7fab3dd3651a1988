// Optional per-stage timing for benchmarks/speed.py and core_speed.py, off by default
// (one relaxed atomic load per timed block when off). Blocks are timed inside the
// parallel loops, so stages are thread-seconds (summed over threads); each parallel
// loop is also recorded task by task (parallelFor).
#pragma once

#include <opencv2/core.hpp>

#include <array>
#include <atomic>
#include <chrono>
#include <vector>

namespace liff {
namespace detail {

enum Stage { kFocalStack, kScaleSpace, kExtrema, kRefinement, kDescriptors, kStageCount };

void setProfiling(bool enabled);
bool profiling();
void resetProfile();
void addStageTime(Stage stage, std::chrono::steady_clock::duration elapsed);
/// Thread-seconds per stage (see above); kExtrema excludes kRefinement. With
/// `inLoops`, only the part timed inside profiled parallel loops (parallelFor).
std::array<double, kStageCount> stageSeconds(bool inLoops = false);

/// Adds the lifetime of this object to `stage` when profiling is on.
class StageTimer {
 public:
  explicit StageTimer(Stage stage) : stage_(stage), on_(profiling()) {
    if (on_) start_ = std::chrono::steady_clock::now();
  }
  ~StageTimer() { stop(); }
  /// Ends the timed block early.
  void stop() {
    if (on_) addStageTime(stage_, std::chrono::steady_clock::now() - start_);
    on_ = false;
  }
  StageTimer(const StageTimer&) = delete;
  StageTimer& operator=(const StageTimer&) = delete;

 private:
  Stage stage_;
  bool on_;
  std::chrono::steady_clock::time_point start_;
};

/// Benchmarks only: build `batch` slices at once whatever the thread count (0: one per
/// thread, the default), so that a one-thread profile has the loops a `batch`-thread
/// call has (results do not depend on it).
void setSliceBatchOverride(int batch);
int sliceBatchOverride();
/// The threads a call splits its work for: cv::getNumThreads(), or the batch override
/// (above), so that a one-thread profile has the tasks of that many threads.
int plannedThreads();

/// One parallel loop as profiled: its wall time and each index's time, in seconds.
/// benchmarks/core_speed.py predicts the speed-up at P threads from these: the time
/// outside loops stays, each loop takes its greedy schedule of tasks over P threads.
struct LoopRecord {
  const char* name = "";  // what the loop computes
  double wall = 0;
  std::vector<double> tasks;
};
void addLoopRecord(LoopRecord record);
/// The loops profiled since the last resetProfile(), outermost only, in call order.
std::vector<LoopRecord> loopRecords();
/// Whether the calling thread is inside a profiled loop (nested loops are part of
/// their outer loop's task).
bool& insideProfiledLoop();

/// cv::parallel_for_ over `range`, a loop called `name`; when profiling, each index runs as its own task,
/// timed, and the loop is recorded (LoopRecord). Results are the same either way:
/// every loop of the core computes each index independently of the split.
template <class Body>
void parallelFor(const char* name, const cv::Range& range, const Body& body) {
  if (!profiling() || insideProfiledLoop()) {
    cv::parallel_for_(range, body);
    return;
  }
  using Clock = std::chrono::steady_clock;
  LoopRecord record;
  record.name = name;
  record.tasks.assign(size_t(std::max(0, range.end - range.start)), 0.0);
  const Clock::time_point start = Clock::now();
  cv::parallel_for_(range, [&](const cv::Range& part) {
    bool& inside = insideProfiledLoop();
    const bool outer = inside;
    inside = true;
    for (int i = part.start; i < part.end; ++i) {
      const Clock::time_point t0 = Clock::now();
      body(cv::Range(i, i + 1));
      record.tasks[size_t(i - range.start)] =
          std::chrono::duration<double>(Clock::now() - t0).count();
    }
    inside = outer;
  });
  record.wall = std::chrono::duration<double>(Clock::now() - start).count();
  addLoopRecord(std::move(record));
}

}  // namespace detail
}  // namespace liff
