// Optional per-stage timing for benchmarks/speed.py, off by default (one relaxed
// atomic load per timed block when off). Blocks are timed inside the parallel
// loops, so stages are thread-seconds (summed over threads). A slice built alone
// with row-parallel blurs counts the wall time of its calling thread.
#pragma once

#include <array>
#include <atomic>
#include <chrono>

namespace liff {
namespace detail {

enum Stage { kFocalStack, kScaleSpace, kExtrema, kRefinement, kDescriptors, kStageCount };

void setProfiling(bool enabled);
bool profiling();
void resetProfile();
void addStageTime(Stage stage, std::chrono::steady_clock::duration elapsed);
/// Thread-seconds per stage (see above); kExtrema excludes kRefinement.
std::array<double, kStageCount> stageSeconds();

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

}  // namespace detail
}  // namespace liff
