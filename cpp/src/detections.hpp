// What a detection pass returns, and the steps after it that need no scale space:
// sorting, deduplication and retaining the strongest (cv::KeyPointsFilter's rule).
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace liff {
namespace detail {

/// Keypoints and, when descriptors are wanted, their descriptors: the blocks the
/// detection wrote (one per batch of slices, rows in the order keypoints were found)
/// and, for keypoint i, its row over all blocks. Sorting and selecting move only
/// keypoints and row numbers; the descriptors are copied once, into the output.
struct Detections {
  std::vector<cv::KeyPoint> keypoints;
  std::vector<cv::Mat> descriptorBlocks;
  std::vector<int> descriptorRows;  // empty when no descriptors are wanted

  /// Appends keypoints found after the present ones, with their descriptors (row j
  /// describing found[j]) when descriptors are wanted, else an empty Mat.
  void append(const std::vector<cv::KeyPoint>& found, const cv::Mat& descriptors);
  /// Keeps the keypoints `rows`, in that order.
  void select(const std::vector<int>& rows);
  /// Row i of `out` (created as keypoints x descriptor size, `type`) describes
  /// keypoint i; `out` is released when there are no keypoints.
  void copyDescriptorsTo(cv::OutputArray out, int descriptorSize, int type) const;
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
