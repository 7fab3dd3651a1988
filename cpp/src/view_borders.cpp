#include "view_borders.hpp"

#include <cmath>
#include <vector>

#include "liff/liff.hpp"
#include "profile.hpp"
#include "slope_range.hpp"

namespace liff {
namespace detail {

int viewsSeeing(const LightField& lf, cv::Point2f pt, double slope) {
  // Along each axis the views whose shifted coordinate stays in the view; the views
  // seeing the point are the product of the two counts.
  auto along = [&](int n, double coordinate, int side) {
    const double centre = 0.5 * (n - 1);
    int seeing = 0;
    for (int i = 0; i < n; ++i) {
      const double shifted = coordinate - slope * (i - centre);
      seeing += shifted >= 0 && shifted <= side - 1;
    }
    return seeing;
  };
  return along(lf.S, pt.x, lf.U) * along(lf.T, pt.y, lf.V);
}

void dropBorderGhosts(const LightField& lf, int layers, Detections& detections) {
  const std::vector<cv::KeyPoint>& keypoints = detections.keypoints;
  const int views = lf.T * lf.S;
  if (views < 2 || keypoints.empty()) return;
  // Decided once per extremum: its orientations share position, size and slope.
  std::vector<int> decidedBy(keypoints.size());
  std::vector<int> tested;
  for (size_t i = 0; i < keypoints.size(); ++i) {
    const cv::KeyPoint& kp = keypoints[i];
    if (viewsSeeing(lf, kp.pt, keypointSlope(kp)) == views) {
      decidedBy[i] = -1;  // every view sees it: kept
      continue;
    }
    const cv::KeyPoint* last = tested.empty() ? nullptr : &keypoints[tested.back()];
    if (!last || last->pt != kp.pt || last->size != kp.size || last->class_id != kp.class_id)
      tested.push_back(int(i));
    decidedBy[i] = int(tested.size()) - 1;
  }
  if (tested.empty()) return;
  std::vector<char> keep(tested.size());
  parallelFor("border features", cv::Range(0, int(tested.size())), [&](const cv::Range& range) {
    for (int j = range.start; j < range.end; ++j) {
      const cv::KeyPoint& kp = keypoints[tested[j]];
      const double slope = keypointSlope(kp);
      int used = 0;
      const double kappa = seenCoherence(lf, kp, slope, layers, nullptr, used);
      keep[j] = used >= 2 && kappa >= minCoherence(used);
    }
  });
  std::vector<int> rows;
  for (size_t i = 0; i < keypoints.size(); ++i)
    if (decidedBy[i] < 0 || keep[decidedBy[i]]) rows.push_back(int(i));
  if (rows.size() < keypoints.size()) detections.select(rows);
}

}  // namespace detail
}  // namespace liff
