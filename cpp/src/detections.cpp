#include "detections.hpp"

#include <algorithm>
#include <functional>
#include <numeric>
#include <tuple>

namespace liff {
namespace detail {

void Detections::select(const std::vector<int>& rows) {
  std::vector<cv::KeyPoint> kept;
  kept.reserve(rows.size());
  for (int i : rows) kept.push_back(keypoints[i]);
  keypoints.swap(kept);
  if (descriptors.empty()) return;
  cv::Mat out(int(rows.size()), descriptors.cols, descriptors.type());
  for (size_t j = 0; j < rows.size(); ++j) descriptors.row(rows[j]).copyTo(out.row(int(j)));
  descriptors = out;
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
