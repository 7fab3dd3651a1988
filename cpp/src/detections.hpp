// What a detection pass returns, and the steps after it that need no scale space:
// sorting, deduplication and retaining the strongest (cv::KeyPointsFilter's rule).
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace liff {
namespace detail {

/// Keypoints and, when descriptors are wanted, their descriptors (row i describes
/// keypoint i; empty otherwise).
struct Detections {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;

  /// Keeps the rows `rows`, in that order.
  void select(const std::vector<int>& rows);
};

/// Sorts by position, size, angle and slope (strongest first among equals) and drops
/// exact duplicates, which arise when two extrema refine to the same point; the
/// order then no longer depends on how the work was split between threads.
void sortAndDeduplicate(Detections& detections);

/// Keeps the `n` strongest keypoints by response and every keypoint tied with the
/// n-th (as cv::KeyPointsFilter::retainBest; n = 0 keeps all), in their order.
void retainBest(Detections& detections, int n);

}  // namespace detail
}  // namespace liff
