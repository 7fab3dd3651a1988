// Input validation and conversion of a stacked Mat into a grey float light field.
#pragma once

#include <opencv2/core.hpp>

namespace liff {
namespace detail {

/// A grey light field L(t, s, v, u) in float, values nominally in [0, 1].
/// `views` is one continuous CV_32F Mat of (T * S * V) rows by U columns:
/// view (t, s) is rows [(t * S + s) * V, (t * S + s + 1) * V).
struct LightField {
  int T = 0, S = 0, V = 0, U = 0;
  cv::Mat views;

  const float* view(int t, int s) const { return views.ptr<float>((t * S + s) * V); }
  cv::Mat viewMat(int t, int s) const { return views.rowRange((t * S + s) * V, (t * S + s + 1) * V); }
  cv::Size viewSize() const { return cv::Size(U, V); }
};

/// Validates a stacked light field Mat (4-D {T, S, V, U} or 2-D {V, U}; 1 or 3
/// channels; 8U, 16U, 32F or 64F) and converts it to grey float.
/// Throws cv::Exception (StsBadArg / StsBadSize) naming what was expected.
/// Never modifies the input; a continuous grey CV_32F input is used without copying.
LightField toGreyLightField(const cv::Mat& input);

/// Validates a detection mask against the centre view size: empty, or CV_8UC1 of V x U.
void checkMask(const cv::Mat& mask, cv::Size viewSize);

}  // namespace detail
}  // namespace liff
