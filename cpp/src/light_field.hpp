// Input validation and conversion of a stacked Mat into a grey float light field.
#pragma once

#include <opencv2/core.hpp>

namespace liff {
namespace detail {

/// A grey light field L(t, s, v, u) in float, values nominally in [0, 1].
/// `views` is one continuous CV_32F Mat of (T * S * V) rows by U columns:
/// view (t, s) is rows [(t * S + s) * V, (t * S + s + 1) * V).
/// When the input carried an alpha channel, `weights` (same layout) holds each
/// sample's validity weight w >= 0 and `views` holds w * L (premultiplied), so the
/// focal stack is sum(w L) / sum(w); otherwise `weights` is empty (all weights 1).
struct LightField {
  int T = 0, S = 0, V = 0, U = 0;
  cv::Mat views;
  cv::Mat weights;
  /// Largest weight (1 without alpha). Only ratios of weights matter, so the focal
  /// stack's "no valid sample reaches this pixel" test is relative to it.
  float maxWeight = 1.f;

  const float* view(int t, int s) const { return views.ptr<float>((t * S + s) * V); }
  cv::Mat viewMat(int t, int s) const { return views.rowRange((t * S + s) * V, (t * S + s + 1) * V); }
  cv::Size viewSize() const { return cv::Size(U, V); }
};

/// Validates a stacked light field Mat (4-D {T, S, V, U} or 2-D {V, U}; 1 (grey),
/// 2 (grey + alpha), 3 (BGR) or 4 (BGRA) channels; 8U, 16U, 32F or 64F) and fills in
/// the sizes, no data yet; throws cv::Exception (StsBadArg / StsBadSize) naming what
/// was expected. Kept apart from the conversion so memory can be checked in between.
LightField checkLightField(const cv::Mat& input);
/// Converts a checked input to grey float in lf.views, with the alpha channel (scaled
/// like the values) as lf.weights; alpha that is 1 everywhere is dropped (same result,
/// less work). Never modifies the input; a continuous grey CV_32F input is used
/// without copying. Throws for NaN / infinite values or negative alpha.
void convertLightField(const cv::Mat& input, LightField& lf);
/// Bytes convertLightField will allocate for a checked input (0 when it can use the
/// input's data as it is).
double conversionBytes(const cv::Mat& input, const LightField& lf);

/// The light field with every view (and its weights) shrunk `factor` times by area
/// averaging (cv::INTER_AREA) to floor(V / factor) x floor(U / factor): a point that
/// moves m pixels per view step moves m / factor in it. Premultiplied views and their
/// weights are averaged alike, so sum(w L) / sum(w) keeps its meaning.
LightField decimate(const LightField& lf, int factor);

/// Validates a detection mask against the centre view size: empty, or CV_8UC1 of V x U.
void checkMask(const cv::Mat& mask, cv::Size viewSize);

}  // namespace detail
}  // namespace liff
