#include "slope_plan.hpp"

#include <algorithm>
#include <cmath>

namespace liff {
namespace detail {
namespace {

void require(bool ok, const cv::String& message) {
  if (!ok) CV_Error(cv::Error::StsOutOfRange, "LiFF: " + message);
}

}  // namespace

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

SlopePlan uniformPlan(const Parameters& p, int T, int S) {
  require(T >= 1 && S >= 1,
          cv::format("T = %d, S = %d views; expected at least 1 view in each direction", T, S));
  require(p.firstSlope <= p.lastSlope,
          cv::format("firstSlope = %g > lastSlope = %g; expected firstSlope <= lastSlope",
                     p.firstSlope, p.lastSlope));
  int n = 1;
  if (T > 1 || S > 1) {
    n = p.numSlopes;
    if (n == 0) {
      n = std::max(T, S) | 1;  // smallest odd number >= max(T, S)
      require(n <= kMaxSlopes,
              cv::format("numSlopes = 0 (automatic) would use %d slopes for %d x %d views; "
                         "expected at most %d: check the axis order (T, S, V, U) or set "
                         "numSlopes", n, T, S, kMaxSlopes));
    }
    require(n == 1 || p.firstSlope < p.lastSlope,
            cv::format("firstSlope = lastSlope = %g with numSlopes = %d; expected "
                       "firstSlope < lastSlope, or numSlopes = 1", p.firstSlope, n));
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
