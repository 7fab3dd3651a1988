// Optional per-stage timing for benchmarks/speed.py: thread-summed seconds per
// stage, off by default (one relaxed atomic load per timed block when off).
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
/// Seconds per stage, summed over threads. kExtrema excludes kRefinement.
std::array<double, kStageCount> stageSeconds();

/// Adds the lifetime of this object to `stage` when profiling is on.
class StageTimer {
 public:
  explicit StageTimer(Stage stage) : stage_(stage), on_(profiling()) {
    if (on_) start_ = std::chrono::steady_clock::now();
  }
  ~StageTimer() {
    if (on_) addStageTime(stage_, std::chrono::steady_clock::now() - start_);
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
