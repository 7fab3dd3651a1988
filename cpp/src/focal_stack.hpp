// Focal stack by shift-and-sum of all views (paper Sec. 3.2, eq. 8), bilinear and
// normalised by the weight of the samples that fall inside each view.
#pragma once

#include "light_field.hpp"

#include <map>
#include <vector>

namespace liff {
namespace detail {

/// Renders the focal slice of each slope m = slopes[k] (pixels per view step) into
/// *slices[k] (CV_32F, V x U):
///
///   F(x, y) = sum_{t,s} sum_taps w * L(t, s, y - m*(t - t_c), x - m*(s - s_c))
///             / sum_{t,s} sum_taps w
///
/// where the taps are the 2x2 bilinear neighbours of the (generally fractional)
/// sample position and only taps inside the view count, so borders do not darken.
/// With per-sample weights a (lf.weights, alpha) every tap's w is also scaled by a:
/// F = sum(w a L) / sum(w a), and F = 0 where no valid sample reaches.
/// Centres: s_c = (S - 1) / 2, t_c = (T - 1) / 2 (fractional for even view counts).
/// All the slopes share one pass over the light field (rows in parallel), which is
/// what bounds the shift-and-sum; each slice is the same whatever slopes it is
/// rendered with.
void renderFocalSlices(const LightField& lf, const std::vector<double>& slopes,
                       const std::vector<cv::Mat*>& slices);

/// Focal slices rendered per pass over the light field when slices are wanted in
/// slope order: the pass is bound by reading the views, and 4 - 6 slopes per pass cost
/// little more than 2 (benchmarks/speed.py, docs/BENCHMARKS.md).
constexpr int kSlicesPerPass = 6;

/// Focal slices of a slope grid for a pass over the slopes in increasing order:
/// prepare() renders the slices asked for that are not ready, together with the next
/// ones not rendered yet while it holds fewer than `ahead` slices, in one pass
/// (renderFocalSlices); take() hands each out. It holds at most max(ahead, slices
/// asked for at once).
class FocalSliceSource {
 public:
  FocalSliceSource(const LightField& lf, const std::vector<double>& slopes, int ahead)
      : lf_(lf), slopes_(slopes), ahead_(ahead) {}
  /// Makes the slices of slope indices `which` ready (rendering those that are not).
  void prepare(const std::vector<int>& which);
  /// The slice of slope index k, made ready by prepare(); the source lets go of it.
  cv::Mat take(int k);

 private:
  const LightField& lf_;
  const std::vector<double>& slopes_;
  int ahead_;
  int next_ = 0;  // slope indices from here on were never rendered
  std::map<int, cv::Mat> ready_;
};

/// Blur variance (pixels^2, along x and y) that bilinear shift-and-sum adds to an
/// in-focus point at `slope`: the 2-tap kernel [1 - f, f] has variance f (1 - f),
/// averaged over the views' fractional shifts f. It is 0 when every shift is whole
/// (slope 0, +-1, ...) and up to 1/4, so without care in-focus slices at fractional
/// slopes are blurrier and detection favours whole slopes. buildScaleSpace tops
/// every slice up to the same variance.
cv::Vec2d interpolationVariance(int T, int S, double slope);

}  // namespace detail
}  // namespace liff
