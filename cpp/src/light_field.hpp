// Input validation and conversion of a stacked Mat into a grey float light field.
#pragma once

#include <opencv2/core.hpp>

#include <vector>

namespace liff {
namespace detail {

/// A grey light field L(t, s, v, u) in float, values nominally in [0, 1].
/// View (t, s) is views[t * S + s]: V x U CV_32F with continuous rows, a header into
/// the caller's data or into the buffer allocate() made.
/// When the input carried an alpha channel, `weights` (same layout) holds each
/// sample's validity weight w >= 0 and `views` holds w * L (premultiplied), so the
/// focal stack is sum(w L) / sum(w); otherwise `weights` is empty (all weights 1).
struct LightField {
  int T = 0, S = 0, V = 0, U = 0;
  std::vector<cv::Mat> views;
  std::vector<cv::Mat> weights;
  /// Largest weight (1 without alpha). Only ratios of weights matter, so the focal
  /// stack's "no valid sample reaches this pixel" test is relative to it.
  float maxWeight = 1.f;

  const float* view(int t, int s) const { return views[size_t(t) * S + s].ptr<float>(); }
  const cv::Mat& viewMat(int t, int s) const { return views[size_t(t) * S + s]; }
  cv::Size viewSize() const { return cv::Size(U, V); }
  /// Allocates every view (and, when `withWeights`, every weight map) as V x U
  /// CV_32F, uninitialised: views one after another in one buffer, weights in another
  /// (kept between calls: working_memory.hpp).
  void allocate(bool withWeights);
};

/// Validates a stacked light field Mat (4-D {T, S, V, U} or 2-D {V, U}; 1 (grey),
/// 2 (grey + alpha), 3 (BGR) or 4 (BGRA) channels; 8U, 16U, 32F or 64F) and fills in
/// the sizes, no data yet; throws cv::Exception (StsBadArg / StsBadSize) naming what
/// was expected. Kept apart from the conversion so memory can be checked in between.
LightField checkLightField(const cv::Mat& input);
/// Converts a checked input to grey float in lf.views, with the alpha channel (scaled
/// like the values) as lf.weights; alpha that is 1 everywhere is dropped (same result,
/// less work). Never modifies the input; a grey CV_32F input whose rows are
/// continuous within each view is used without copying. Throws for NaN / infinite values or negative alpha.
void convertLightField(const cv::Mat& input, LightField& lf);
/// Bytes convertLightField will allocate for a checked input (only the views' headers
/// when it can use the input's data as it is).
double conversionBytes(const cv::Mat& input, const LightField& lf);

/// The light field with every view (and its weights) shrunk `factor` times by area
/// averaging (cv::INTER_AREA) to floor(V / factor) x floor(U / factor): a point that
/// moves m pixels per view step moves m / factor in it. Premultiplied views and their
/// weights are averaged alike, so sum(w L) / sum(w) keeps its meaning.
LightField decimate(const LightField& lf, int factor);

/// decimate(decimate(lf, first), second) into `twice`, and of decimate(lf, first) only
/// the views (and weights) `keepOnce` marks (T * S flags, LightField layout) into
/// `once`, the others left empty: the same values as the two calls, without holding
/// every view decimated once.
void decimateTwice(const LightField& lf, int first, int second,
                   const std::vector<bool>& keepOnce, LightField& once, LightField& twice);

/// Validates a detection mask against the centre view size: empty, or CV_8UC1 of V x U.
void checkMask(const cv::Mat& mask, cv::Size viewSize);

}  // namespace detail
}  // namespace liff
