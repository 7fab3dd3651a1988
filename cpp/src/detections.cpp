#include "detections.hpp"

#include "profile.hpp"

#include <algorithm>
#include <cstring>
#include <functional>
#include <numeric>
#include <tuple>

namespace liff {
namespace detail {
namespace {

// Descriptor rows one parallel task copies into the output.
constexpr int kRowsPerCopyTask = 256;

}  // namespace

void Detections::append(const std::vector<cv::KeyPoint>& found, const cv::Mat& descriptors) {
  if (!descriptors.empty()) {
    CV_Assert(descriptors.rows == int(found.size()));
    int next = 0;
    for (const cv::Mat& block : descriptorBlocks) next += block.rows;
    for (int j = 0; j < descriptors.rows; ++j) descriptorRows.push_back(next + j);
    descriptorBlocks.push_back(descriptors);
  }
  keypoints.insert(keypoints.end(), found.begin(), found.end());
}

void Detections::select(const std::vector<int>& rows) {
  std::vector<cv::KeyPoint> kept;
  kept.reserve(rows.size());
  for (int i : rows) kept.push_back(keypoints[i]);
  keypoints.swap(kept);
  if (descriptorRows.empty()) return;
  std::vector<int> keptRows;
  keptRows.reserve(rows.size());
  for (int i : rows) keptRows.push_back(descriptorRows[i]);
  descriptorRows.swap(keptRows);
}

void Detections::copyDescriptorsTo(cv::OutputArray out, int descriptorSize, int type) const {
  if (keypoints.empty()) {
    out.release();
    return;
  }
  CV_Assert(descriptorRows.size() == keypoints.size());
  out.create(int(keypoints.size()), descriptorSize, type);
  cv::Mat dst = out.getMat();
  // Where each block starts among all rows; a row is found by a binary search.
  std::vector<int> starts{0};
  for (const cv::Mat& block : descriptorBlocks) starts.push_back(starts.back() + block.rows);
  const size_t rowBytes = dst.elemSize() * size_t(descriptorSize);
  const int tasks = (int(descriptorRows.size()) + kRowsPerCopyTask - 1) / kRowsPerCopyTask;
  parallelFor("descriptor copy", cv::Range(0, tasks), [&](const cv::Range& range) {
    const int end = std::min(int(descriptorRows.size()), range.end * kRowsPerCopyTask);
    for (int i = range.start * kRowsPerCopyTask; i < end; ++i) {
      const int row = descriptorRows[i];
      const size_t b = size_t(std::upper_bound(starts.begin(), starts.end(), row) - starts.begin()) - 1;
      const cv::Mat& block = descriptorBlocks[b];
      CV_DbgAssert(block.type() == type && block.cols == descriptorSize);
      std::memcpy(dst.ptr(i), block.ptr(row - starts[b]), rowBytes);
    }
  });
}

void sortAndDeduplicate(Detections& detections) {
  const std::vector<cv::KeyPoint>& keypoints = detections.keypoints;
  std::vector<int> order(keypoints.size());
  std::iota(order.begin(), order.end(), 0);
  auto key = [&](int i) {
    const cv::KeyPoint& k = keypoints[i];
    return std::make_tuple(k.pt.x, k.pt.y, k.size, k.angle, k.class_id, -k.response, k.octave);
  };
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return key(a) < key(b); });
  std::vector<int> unique;
  for (int i : order) {
    const cv::KeyPoint& k = keypoints[i];
    if (!unique.empty()) {
      const cv::KeyPoint& p = keypoints[unique.back()];
      if (p.pt == k.pt && p.size == k.size && p.angle == k.angle && p.class_id == k.class_id)
        continue;
    }
    unique.push_back(i);
  }
  detections.select(unique);
}

void retainBest(Detections& detections, int n) {
  const std::vector<cv::KeyPoint>& keypoints = detections.keypoints;
  if (n <= 0 || int(keypoints.size()) <= n) return;
  // cv::KeyPointsFilter::retainBest's rule: the n-th strongest response is the bar,
  // and every keypoint that reaches it stays, so the orientations of one extremum
  // (equal responses) are kept or dropped together.
  std::vector<float> responses;
  responses.reserve(keypoints.size());
  for (const cv::KeyPoint& k : keypoints) responses.push_back(k.response);
  std::nth_element(responses.begin(), responses.begin() + (n - 1), responses.end(),
                   std::greater<float>());
  const float bar = responses[n - 1];
  std::vector<int> kept;
  for (int i = 0; i < int(keypoints.size()); ++i)
    if (keypoints[i].response >= bar) kept.push_back(i);
  detections.select(kept);
}

}  // namespace detail
}  // namespace liff
