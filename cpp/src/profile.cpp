#include "profile.hpp"

namespace liff {
namespace detail {
namespace {
std::atomic<bool> gEnabled{false};
std::array<std::atomic<long long>, kStageCount> gNanoseconds{};
}  // namespace

void setProfiling(bool enabled) { gEnabled.store(enabled, std::memory_order_relaxed); }
bool profiling() { return gEnabled.load(std::memory_order_relaxed); }
void resetProfile() {
  for (auto& ns : gNanoseconds) ns.store(0);
}
void addStageTime(Stage stage, std::chrono::steady_clock::duration elapsed) {
  gNanoseconds[stage].fetch_add(
      std::chrono::duration_cast<std::chrono::nanoseconds>(elapsed).count(),
      std::memory_order_relaxed);
}
std::array<double, kStageCount> stageSeconds() {
  std::array<double, kStageCount> seconds{};
  for (int i = 0; i < kStageCount; ++i) seconds[i] = gNanoseconds[i].load() * 1e-9;
  seconds[kExtrema] -= seconds[kRefinement];  // refinement is timed inside the search
  return seconds;
}

}  // namespace detail
}  // namespace liff
