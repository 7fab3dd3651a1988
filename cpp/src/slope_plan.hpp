// The slopes of the focal stack: which focal slices a call renders, and which of
// them are searched for extrema.
#pragma once

#include <liff/parameters.hpp>
#include <vector>

namespace liff {
namespace detail {

/// Slopes beyond this many pixels per view step are surely a mistake.
constexpr double kMaxAbsSlope = 1e4;
/// More slopes than this is surely a mistake (each costs a full SIFT pass).
constexpr int kMaxSlopes = 4096;

/// The focal slices of one call, in increasing slope. Slice k sits at grid position
/// grid[k]: slopes[k] = origin + grid[k] * step (up to rounding), so slices with
/// consecutive grid positions are slope neighbours. A searched slice is compared
/// with its neighbours in the 80-neighbour test; an unsearched one is rendered only
/// as a neighbour. A searched slice without a neighbour on one side (the ends of an
/// explicit range) skips that side.
struct SlopePlan {
  std::vector<double> slopes;
  std::vector<int> grid;
  std::vector<bool> searched;
  double origin = 0;
  double step = 0;  // 0 for a single slice
  /// An automatic range whose survey found nothing: the paper's [-1, 1] (cut by a bound).
  bool surveyFoundNothing = false;
  /// An automatic range whose survey saw structure at or beyond largestSlope.
  bool structureBeyondReach = false;
  /// Interpolation blur (view pixels^2, along x and y) every slice is topped up to: the
  /// largest any slice of the plan's grid carries (see interpolationVariance), so that
  /// all slices are equally sharp whichever of them a call builds.
  cv::Vec2d blurTarget{0, 0};

  int size() const { return int(slopes.size()); }
  /// Index of the slice nearest to `slope` on the grid (the slice a keypoint is
  /// described on); -1 for an empty plan.
  int nearest(double slope) const;
  /// Whether slices k and k + 1 are neighbours on the grid.
  bool adjacent(int k) const { return grid[k + 1] == grid[k] + 1; }
};

/// Sets plan.blurTarget for T x S views: the largest interpolation blur over the plan's
/// slopes, or with `wholeGrid` over a full period of its grid origin + k * step (when
/// (max(T, S) - 1) * step / 2 is a whole number of pixels, N - 1 positions), so that
/// plans holding different parts of one grid blur alike.
void setBlurTarget(SlopePlan& plan, int T, int S, bool wholeGrid);

/// The slopes linspace(first, last, n); n == 1 gives the midpoint (first + last) / 2.
std::vector<double> slopeGrid(double first, double last, int n);

/// Whether `parameters` ask for the automatic slope range (an infinite bound).
bool automaticRange(const Parameters& parameters);

/// The slope an automatic range's grid passes through: the finite bound of a
/// half-automatic range (so that a slice lies on it), else 0; a single view's one slope.
double gridOrigin(const Parameters& parameters);

/// The uniform plan of `parameters` (a finite range) for T x S views:
/// linspace(firstSlope, lastSlope, n), every slice searched; n = numSlopes, or for
/// numSlopes = 0 the smallest odd number that keeps neighbouring slices at most one
/// pixel of parallax apart at the outermost view (spacing <= 2 / (max(T, S) - 1);
/// for [-1, 1] the paper's rule, the smallest odd number >= max(T, S)); a single view
/// has the one slope (firstSlope + lastSlope) / 2. Throws cv::Exception
/// (StsOutOfRange) when the slopes are out of order, infinite or too many. Its
/// blurTarget is left 0: setBlurTarget before rendering.
SlopePlan uniformPlan(const Parameters& parameters, int T, int S);

}  // namespace detail
}  // namespace liff
