#include "profile.hpp"

#include <algorithm>
#include <mutex>

namespace liff {
namespace detail {
namespace {
std::atomic<bool> gEnabled{false};
std::array<std::atomic<long long>, kStageCount> gNanoseconds{}, gNanosecondsInLoops{};
std::mutex gLoopMutex;
std::vector<LoopRecord> gLoops;
}  // namespace

std::atomic<int> gBatchOverride{0};
void setSliceBatchOverride(int batch) { gBatchOverride.store(std::max(0, batch)); }
int sliceBatchOverride() { return gBatchOverride.load(); }
int plannedThreads() {
  const int batch = sliceBatchOverride();
  return batch > 0 ? batch : cv::getNumThreads();
}

void addLoopRecord(LoopRecord record) {
  std::lock_guard<std::mutex> lock(gLoopMutex);
  gLoops.push_back(std::move(record));
}

std::vector<LoopRecord> loopRecords() {
  std::lock_guard<std::mutex> lock(gLoopMutex);
  return gLoops;
}

bool& insideProfiledLoop() {
  thread_local bool inside = false;
  return inside;
}

void setProfiling(bool enabled) { gEnabled.store(enabled, std::memory_order_relaxed); }
bool profiling() { return gEnabled.load(std::memory_order_relaxed); }
void resetProfile() {
  for (auto& ns : gNanoseconds) ns.store(0);
  for (auto& ns : gNanosecondsInLoops) ns.store(0);
  std::lock_guard<std::mutex> lock(gLoopMutex);
  gLoops.clear();
}
void addStageTime(Stage stage, std::chrono::steady_clock::duration elapsed) {
  const long long ns = std::chrono::duration_cast<std::chrono::nanoseconds>(elapsed).count();
  gNanoseconds[stage].fetch_add(ns, std::memory_order_relaxed);
  if (insideProfiledLoop()) gNanosecondsInLoops[stage].fetch_add(ns, std::memory_order_relaxed);
}
std::array<double, kStageCount> stageSeconds(bool inLoops) {
  std::array<double, kStageCount> seconds{};
  for (int i = 0; i < kStageCount; ++i)
    seconds[i] = (inLoops ? gNanosecondsInLoops : gNanoseconds)[i].load() * 1e-9;
  seconds[kExtrema] -= seconds[kRefinement];  // refinement is timed inside the search
  return seconds;
}

}  // namespace detail
}  // namespace liff
