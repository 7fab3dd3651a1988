#include "slice_window.hpp"

#include <algorithm>

#include "profile.hpp"

namespace liff {
namespace detail {

SliceWindow::SliceWindow(const LightField& lf, const SlopePlan& plan,
                         const ScaleSpaceSettings& settings, int batch, int renderAhead)
    : lf_(lf),
      plan_(plan),
      settings_(settings),
      batch_(batch),
      source_(lf, plan.slopes, renderAhead) {}

void SliceWindow::require(const std::vector<int>& which) {
  std::vector<int> missing;
  for (int k : which)
    if (!holds(k) && std::find(missing.begin(), missing.end(), k) == missing.end())
      missing.push_back(k);
  if (!missing.empty()) build(missing);
}

const ScaleSpace* SliceWindow::below(int k) const {
  return k > 0 && plan_.adjacent(k - 1) ? &at(k - 1) : nullptr;
}

const ScaleSpace* SliceWindow::above(int k) const {
  return k + 1 < plan_.size() && plan_.adjacent(k) ? &at(k + 1) : nullptr;
}

void SliceWindow::releaseBelow(int k) {
  for (auto it = spaces_.begin(); it != spaces_.end() && it->first < k;) {
    pool_.giveSpace(std::move(it->second));
    it = spaces_.erase(it);
  }
}

void SliceWindow::releaseAll() { releaseBelow(plan_.size()); }

void SliceWindow::build(const std::vector<int>& which) {
  const int n = int(which.size());
  source_.prepare(which);
  std::vector<cv::Mat> slices;
  for (int k : which) slices.push_back(source_.take(k));
  auto buildOne = [&](int j, bool rowParallel) {
    StageTimer timer(kScaleSpace);
    std::unique_ptr<BuildScratch> scratch = pool_.takeScratch();
    std::shared_ptr<ScaleSpace> space = pool_.takeSpace();
    const cv::Vec2d variance = interpolationVariance(lf_.T, lf_.S, plan_.slopes[which[j]]);
    buildScaleSpace(slices[j], settings_.layers, settings_.sigma, settings_.octaves, variance,
                    plan_.blurTarget, settings_.detectionOnly, rowParallel, *space, scratch.get());
    slices[j].release();
    pool_.giveScratch(std::move(scratch));
    return space;
  };
  // Whole rounds of one slice per thread run in parallel (each slice serial inside);
  // the remainder is built one slice at a time with the parallelism inside it
  // (row-parallel blurs), so no thread idles.
  const int threads = std::max(1, std::min(cv::getNumThreads(), batch_));
  const int parallelCount = threads > 1 ? n - n % threads : 0;
  std::vector<std::shared_ptr<ScaleSpace>> built(n);
  cv::parallel_for_(
      cv::Range(0, parallelCount),
      [&](const cv::Range& range) {
        for (int j = range.start; j < range.end; ++j) built[j] = buildOne(j, false);
      },
      threads);  // `threads` stripes: no more than that many built at once
  for (int j = parallelCount; j < n; ++j) built[j] = buildOne(j, true);
  for (int j = 0; j < n; ++j) spaces_[which[j]] = built[j];
}

}  // namespace detail
}  // namespace liff
