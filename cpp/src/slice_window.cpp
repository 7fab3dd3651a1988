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
  source_.prepare(which);
  // Groups of at most `batch` slices (the memory estimate's count of slices being
  // built at once) advance in step, each step parallel over their row stripes.
  for (size_t first = 0; first < which.size(); first += batch_) {
    const size_t last = std::min(which.size(), first + size_t(batch_));
    std::vector<cv::Mat> slices;
    std::vector<std::unique_ptr<BuildScratch>> scratch;
    std::vector<std::shared_ptr<ScaleSpace>> built;
    std::vector<SliceBuild> builds;
    for (size_t j = first; j < last; ++j) {
      slices.push_back(source_.take(which[j]));
      scratch.push_back(pool_.takeScratch());
      built.push_back(pool_.takeSpace());
    }
    for (size_t j = first; j < last; ++j)
      builds.push_back({&slices[j - first],
                        interpolationVariance(lf_.T, lf_.S, plan_.slopes[which[j]]),
                        built[j - first].get(), scratch[j - first].get()});
    buildScaleSpaces(builds, settings_.layers, settings_.sigma, settings_.octaves,
                     settings_.firstOctave, plan_.blurTarget, settings_.detectionOnly);
    for (size_t j = first; j < last; ++j) spaces_[which[j]] = built[j - first];
    for (std::unique_ptr<BuildScratch>& s : scratch) pool_.giveScratch(std::move(s));
  }
}

}  // namespace detail
}  // namespace liff
