#include "slope_plan.hpp"

#include <algorithm>
#include <cmath>
#include <liff/liff.hpp>

#include "focal_stack.hpp"
#include "require.hpp"

namespace liff {
namespace detail {

int SlopePlan::nearest(double slope) const {
  if (slopes.empty()) return -1;
  if (slopes.size() == 1 || step == 0) return 0;
  // The grid position nearest to `slope`, then the slice at (or nearest to) it.
  const double position = std::lround((slope - origin) / step);
  const auto it = std::lower_bound(grid.begin(), grid.end(), position);
  if (it == grid.end()) return size() - 1;
  const int k = int(it - grid.begin());
  if (*it == position || k == 0) return k;
  return position - grid[k - 1] <= *it - position ? k - 1 : k;
}

void setBlurTarget(SlopePlan& plan, int T, int S, bool wholeGrid) {
  std::vector<double> slopes = plan.slopes;
  if (wholeGrid) {
    slopes.clear();
    for (int k = 0; k < std::max(1, std::max(T, S) - 1); ++k)
      slopes.push_back(plan.origin + k * plan.step);
  }
  plan.blurTarget = cv::Vec2d(0, 0);
  for (double slope : slopes) {
    const cv::Vec2d v = interpolationVariance(T, S, slope);
    plan.blurTarget =
        cv::Vec2d(std::max(plan.blurTarget[0], v[0]), std::max(plan.blurTarget[1], v[1]));
  }
}

std::vector<double> slopeGrid(double first, double last, int n) {
  std::vector<double> slopes;
  if (n == 1) {
    slopes.push_back(0.5 * (first + last));
    return slopes;
  }
  for (int i = 0; i < n; ++i) slopes.push_back(first + (last - first) * i / double(n - 1));
  slopes.back() = last;  // the formula can round one ulp past `last`
  return slopes;
}

bool automaticRange(const Parameters& p) {
  return std::isinf(p.firstSlope) || std::isinf(p.lastSlope);
}

double gridOrigin(const Parameters& p) {
  return std::isfinite(p.firstSlope) ? p.firstSlope : std::isfinite(p.lastSlope) ? p.lastSlope : 0.0;
}

SlopePlan uniformPlan(const Parameters& p, int T, int S) {
  require(T >= 1 && S >= 1,
          cv::format("T = %d, S = %d views; expected at least 1 view in each direction", T, S));
  require(std::isfinite(p.firstSlope) && std::isfinite(p.lastSlope),
          "a uniform plan needs a finite slope range");
  require(p.firstSlope <= p.lastSlope,
          cv::format("firstSlope = %g > lastSlope = %g; expected firstSlope <= lastSlope",
                     p.firstSlope, p.lastSlope));
  int n = 1;
  if (T > 1 || S > 1) {
    n = p.numSlopes;
    if (n == 0) {
      // At most 2 / (N - 1) apart: n - 1 >= (last - first) (N - 1) / 2, rounded up to odd
      // (so a range symmetric about 0 keeps slope 0). The 1e-9 absorbs rounding in
      // ranges that are whole multiples of the spacing.
      const double intervals = (p.lastSlope - p.firstSlope) * (std::max(T, S) - 1) / 2.0;
      const double wanted = std::max(3.0, std::ceil(intervals - 1e-9) + 1);
      const double odd = std::fmod(wanted, 2.0) == 0 ? wanted + 1 : wanted;
      require(odd <= kMaxSlopes,
              cv::format("numSlopes = 0 would use %.0f slopes for [%g, %g] and %d x %d views; "
                         "expected at most %d: check the axis order (T, S, V, U), narrow the "
                         "range or set numSlopes",
                         odd, p.firstSlope, p.lastSlope, T, S, kMaxSlopes));
      n = int(odd);
    }
    require(n == 1 || p.firstSlope < p.lastSlope,
            cv::format("firstSlope = lastSlope = %g with numSlopes = %d; expected "
                       "firstSlope < lastSlope, or numSlopes = 1",
                       p.firstSlope, n));
    // Slices closer than class_id's slope resolution could not be told apart in the
    // keypoints (and a subnormal spacing rounds to repeated slopes).
    require(n == 1 || (p.lastSlope - p.firstSlope) / (n - 1) >= 1.0 / kSlopeScale,
            cv::format("firstSlope = %g and lastSlope = %g with %d slopes are %g apart; "
                       "expected slices at least 1/%.0f px per view step apart (the slope "
                       "resolution of class_id): widen the range, or use fewer slopes "
                       "(numSlopes = 1 for one slice)",
                       p.firstSlope, p.lastSlope, n, (p.lastSlope - p.firstSlope) / (n - 1),
                       kSlopeScale));
  }
  SlopePlan plan;
  plan.slopes = slopeGrid(p.firstSlope, p.lastSlope, n);
  for (int k = 0; k < n; ++k) plan.grid.push_back(k);
  plan.searched.assign(n, true);
  plan.origin = plan.slopes.front();
  plan.step = n > 1 ? (p.lastSlope - p.firstSlope) / (n - 1) : 0.0;
  return plan;
}

}  // namespace detail
}  // namespace liff
