// The focal stack (focal_stack.hpp): slices by shift-and-sum of the views,
//
//   F(x, y) = sum_{t,s} sum_taps w a L(t, s, y - m (t - t_c), x - m (s - s_c))
//             / sum_{t,s} sum_taps w a,
//
// bilinear taps w, only taps inside the view, a = alpha (1 without).
#include "focal_stack.hpp"
#include "profile.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace {

using liff::detail::LightField;
using liff::detail::renderFocalSlices;

// A T x S light field of V x U views, all zero.
LightField zeroLightField(int T, int S, int V, int U) {
  LightField lf;
  lf.T = T;
  lf.S = S;
  lf.V = V;
  lf.U = U;
  lf.allocate(false);
  for (cv::Mat& view : lf.views) view.setTo(0);
  return lf;
}

float& sample(std::vector<cv::Mat>& views, const LightField& lf, int t, int s, int v, int u) {
  return views[size_t(t) * lf.S + s].at<float>(v, u);
}
float sample(const std::vector<cv::Mat>& views, const LightField& lf, int t, int s, int v,
             int u) {
  return views[size_t(t) * lf.S + s].at<float>(v, u);
}

// Random values k / 256, k in [0, 256): sums of a few hundred of them are exact in float,
// so any summation order gives the same slice.
LightField dyadicLightField(int T, int S, int V, int U, uint64 seed) {
  LightField lf = zeroLightField(T, S, V, U);
  cv::RNG rng(seed);
  for (cv::Mat& view : lf.views)
    for (int v = 0; v < V; ++v)
      for (int u = 0; u < U; ++u) view.at<float>(v, u) = float(rng.uniform(0, 256)) / 256.f;
  return lf;
}

std::vector<cv::Mat> render(const LightField& lf, const std::vector<double>& slopes) {
  std::vector<cv::Mat> slices(slopes.size());
  std::vector<cv::Mat*> outputs;
  for (cv::Mat& slice : slices) outputs.push_back(&slice);
  renderFocalSlices(lf, slopes, outputs);
  return slices;
}

// The 2-tap bilinear kernel of a sample at position p of an axis of n pixels: the taps
// floor(p) and floor(p) + 1 with weights (1 - f, f), f = p - floor(p); taps outside
// [0, n) are dropped (weight 0).
struct Taps {
  int index[2];
  double weight[2];
  Taps(double p, int n) {
    const double p0 = std::floor(p), f = p - p0;
    index[0] = int(p0);
    index[1] = int(p0) + 1;
    weight[0] = index[0] >= 0 && index[0] < n ? 1 - f : 0;
    weight[1] = index[1] >= 0 && index[1] < n ? f : 0;
  }
};

// The slice at `slope` straight from the formula above, pixel by pixel, in double. With
// alpha, lf.views holds a L (premultiplied) and lf.weights a, as convertLightField makes
// them. Pixels no valid sample reaches are 0.
cv::Mat referenceSlice(const LightField& lf, double slope) {
  const double tc = 0.5 * (lf.T - 1), sc = 0.5 * (lf.S - 1);
  cv::Mat slice(lf.V, lf.U, CV_32F);
  for (int y = 0; y < lf.V; ++y)
    for (int x = 0; x < lf.U; ++x) {
      double sum = 0, weight = 0;
      for (int t = 0; t < lf.T; ++t)
        for (int s = 0; s < lf.S; ++s) {
          const Taps ty(y - slope * (t - tc), lf.V), tx(x - slope * (s - sc), lf.U);
          for (int i = 0; i < 2; ++i)
            for (int j = 0; j < 2; ++j) {
              const double w = ty.weight[i] * tx.weight[j];
              if (w == 0) continue;
              sum += w * sample(lf.views, lf, t, s, ty.index[i], tx.index[j]);
              weight += w * (lf.weights.empty()
                                 ? 1.0
                                 : sample(lf.weights, lf, t, s, ty.index[i], tx.index[j]));
            }
        }
      slice.at<float>(y, x) = weight > 0 ? float(sum / weight) : 0.f;
    }
  return slice;
}

// Largest |a - b| over two slices.
double maxDifference(const cv::Mat& a, const cv::Mat& b) { return cv::norm(a, b, cv::NORM_INF); }

// --- Whole slopes: a mean of views shifted by whole pixels ------------------------------

// With odd view counts the centre (t_c, s_c) is a view and a whole slope m shifts every
// view by whole pixels: each slice pixel is the plain mean of one sample per view whose
// sample is inside. The inputs are multiples of 1/256, so every sum is exact and the
// slice must equal float(sum) / float(count) bit for bit.
void expectMeanOfShiftedViews(double slope, bool interior) {
  const LightField lf = dyadicLightField(3, 5, 20, 24, 7);
  const cv::Mat slice = render(lf, {slope})[0];
  const int m = int(slope), tc = (lf.T - 1) / 2, sc = (lf.S - 1) / 2;
  int checked = 0;
  for (int y = 0; y < lf.V; ++y)
    for (int x = 0; x < lf.U; ++x) {
      float sum = 0;
      int count = 0;
      for (int t = 0; t < lf.T; ++t)
        for (int s = 0; s < lf.S; ++s) {
          const int v = y - m * (t - tc), u = x - m * (s - sc);
          if (v < 0 || v >= lf.V || u < 0 || u >= lf.U) continue;
          sum += sample(lf.views, lf, t, s, v, u);
          ++count;
        }
      const bool everyView = count == lf.T * lf.S;
      if (everyView != interior) continue;
      ASSERT_EQ(slice.at<float>(y, x), sum / float(count))
          << "slope " << slope << ", pixel (" << x << ", " << y << "), " << count << " views";
      ++checked;
    }
  // The interior is (U - 2 |m| s_c) x (V - 2 |m| t_c) pixels; the border is the rest.
  const int inner = (lf.U - 2 * std::abs(m) * sc) * (lf.V - 2 * std::abs(m) * tc);
  EXPECT_EQ(checked, interior ? inner : lf.U * lf.V - inner) << "slope " << slope;
}

TEST(FocalStack, WholeSlopeSliceIsTheMeanOfTheViewsShiftedByWholePixels) {
  for (double slope : {0.0, 1.0, -2.0}) expectMeanOfShiftedViews(slope, true);
}

TEST(FocalStack, WholeSlopeBorderPixelsAverageOnlyTheViewsThatReachThem) {
  for (double slope : {1.0, -2.0}) expectMeanOfShiftedViews(slope, false);
}

// --- Fractional slopes: bilinear weights and border normalisation ------------------------

// Two views along one axis (centre 0.5 between them) and slope 0.3: view 1 is sampled at
// x - 0.3 * 0.5 = x - 0.15, i.e. 0.15 of pixel x - 1 plus 0.85 of pixel x. An impulse of
// 1 at pixel 8 of view 1 (view 0 black) is a scene point at 8.15: the slice holds
// 0.85 / 2 at 8 and 0.15 / 2 at 9 (two views of weight 1 each), 0 elsewhere.
TEST(FocalStack, FractionalShiftSplitsASampleByTheBilinearWeights) {
  constexpr double kSlope = 0.3;
  constexpr int kImpulse = 8, kSide = 16;
  for (bool alongX : {true, false}) {
    SCOPED_TRACE(alongX ? "views along s (x)" : "views along t (y)");
    LightField lf = alongX ? zeroLightField(1, 2, kSide, kSide) : zeroLightField(2, 1, kSide, kSide);
    for (int i = 0; i < kSide; ++i) {
      if (alongX)
        sample(lf.views, lf, 0, 1, i, kImpulse) = 1.f;
      else
        sample(lf.views, lf, 1, 0, kImpulse, i) = 1.f;
    }
    const cv::Mat slice = render(lf, {kSlope})[0];
    for (int i = 0; i < kSide; ++i)
      for (int p = 0; p < kSide; ++p) {
        const float value = alongX ? slice.at<float>(i, p) : slice.at<float>(p, i);
        const float expected = p == kImpulse ? 0.425f : p == kImpulse + 1 ? 0.075f : 0.f;
        ASSERT_NEAR(value, expected, 1e-6) << "position " << p;
      }
  }
}

// Any slope, even view counts (fractional centre), shifts beyond a view: a constant light
// field gives the same constant everywhere, borders included, since each pixel is divided
// by the weight of the taps that fell inside the views.
TEST(FocalStack, ConstantLightFieldGivesTheSameConstantUpToTheBorders) {
  constexpr float kGrey = 0.6f;
  LightField lf = zeroLightField(4, 3, 12, 14);
  for (cv::Mat& view : lf.views) view.setTo(kGrey);
  const std::vector<double> slopes{-1.7, -0.35, 0.5, 1.25, 3.0};
  const std::vector<cv::Mat> slices = render(lf, slopes);
  for (size_t k = 0; k < slopes.size(); ++k) {
    double lo, hi;
    cv::minMaxLoc(slices[k], &lo, &hi);
    EXPECT_NEAR(lo, kGrey, 1e-6) << "slope " << slopes[k];
    EXPECT_NEAR(hi, kGrey, 1e-6) << "slope " << slopes[k];
  }
}

// Random values, odd and even view counts, several row tasks, slopes fractional and whole
// and large enough to leave views: every pixel equals the formula.
TEST(FocalStack, SliceEqualsTheShiftAndSumFormulaAtEveryPixel) {
  const std::vector<double> slopes{-2.6, -1.0, -0.45, 0.0, 0.2, 0.75, 1.5};
  for (cv::Size views : {cv::Size(4, 3), cv::Size(5, 5), cv::Size(2, 1)}) {
    const LightField lf = dyadicLightField(views.height, views.width, 37, 29, 11);
    const std::vector<cv::Mat> slices = render(lf, slopes);
    for (size_t k = 0; k < slopes.size(); ++k)
      EXPECT_LT(maxDifference(slices[k], referenceSlice(lf, slopes[k])), 1e-6)
          << views.height << " x " << views.width << " views, slope " << slopes[k];
  }
}

// Views wide enough for the vector paths (32 and 8 columns at a time, and the 8-column
// vectors at the borders where some views' taps leave the row and others' do not).
TEST(FocalStack, WideSliceEqualsTheShiftAndSumFormulaAtEveryPixel) {
  const std::vector<double> slopes{-4.3, -1.25, 0.0, 0.35, 2.0, 6.5};
  for (int U : {8, 40, 107}) {
    const LightField lf = dyadicLightField(3, 7, 6, U, 13);
    const std::vector<cv::Mat> slices = render(lf, slopes);
    for (size_t k = 0; k < slopes.size(); ++k)
      EXPECT_LT(maxDifference(slices[k], referenceSlice(lf, slopes[k])), 1e-6)
          << U << " columns, slope " << slopes[k];
  }
}

TEST(FocalStack, SliceIsTheSameWhateverSlopesItIsRenderedWith) {
  const LightField lf = dyadicLightField(3, 4, 37, 29, 5);
  const std::vector<double> slopes{-0.8, 0.15, 0.6};
  const std::vector<cv::Mat> together = render(lf, slopes);
  for (size_t k = 0; k < slopes.size(); ++k)
    EXPECT_EQ(maxDifference(together[k], render(lf, {slopes[k]})[0]), 0) << slopes[k];
}

// The rows each task renders follow the threads the call plans for (8 to 32 rows); every
// split gives the same slices bit for bit, alpha or not (alphaLightField below).
LightField alphaLightField(int T, int S, int V, int U);

TEST(FocalStack, SliceIsTheSameWhateverTheThreadsItIsSplitFor) {
  const std::vector<double> slopes{-1.7, -0.35, 0.0, 0.9};
  for (bool alpha : {false, true}) {
    const LightField lf =
        alpha ? alphaLightField(5, 5, 301, 47) : dyadicLightField(5, 5, 301, 47, 7);
    liff::detail::setSliceBatchOverride(1);  // one thread: 32 rows a task
    const std::vector<cv::Mat> few = render(lf, slopes);
    liff::detail::setSliceBatchOverride(64);  // 64 threads: 8 rows a task
    const std::vector<cv::Mat> many = render(lf, slopes);
    liff::detail::setSliceBatchOverride(3);  // 25 rows a task, a ragged last one
    const std::vector<cv::Mat> some = render(lf, slopes);
    liff::detail::setSliceBatchOverride(0);
    for (size_t k = 0; k < slopes.size(); ++k) {
      EXPECT_EQ(maxDifference(few[k], many[k]), 0) << "alpha " << alpha << ", slope " << slopes[k];
      EXPECT_EQ(maxDifference(few[k], some[k]), 0) << "alpha " << alpha << ", slope " << slopes[k];
    }
  }
}

// --- Alpha: F = sum(a L) / sum(a) ----------------------------------------------------------

// A light field with random values and random alpha in [0, 1], a quarter of it 0; views
// premultiplied as convertLightField leaves them.
LightField alphaLightField(int T, int S, int V, int U) {
  LightField lf = dyadicLightField(T, S, V, U, 3);
  cv::RNG rng(9);
  double maxWeight = 0;
  for (cv::Mat& view : lf.views) {
    cv::Mat weight(V, U, CV_32F);
    for (int v = 0; v < V; ++v)
      for (int u = 0; u < U; ++u) {
        const float a = rng.uniform(0.f, 1.f) < 0.25f ? 0.f : float(rng.uniform(1, 257)) / 256.f;
        weight.at<float>(v, u) = a;
        view.at<float>(v, u) *= a;
        maxWeight = std::max(maxWeight, double(a));
      }
    lf.weights.push_back(weight);
  }
  lf.maxWeight = float(maxWeight);
  return lf;
}

// At slope 0 every view is sampled at the pixel itself: F = sum_ts a L / sum_ts a.
TEST(FocalStack, AlphaSliceAtSlopeZeroIsSumOfALOverSumOfA) {
  const LightField lf = alphaLightField(3, 3, 18, 20);
  const cv::Mat slice = render(lf, {0.0})[0];
  for (int y = 0; y < lf.V; ++y)
    for (int x = 0; x < lf.U; ++x) {
      double aL = 0, a = 0;
      for (int t = 0; t < lf.T; ++t)
        for (int s = 0; s < lf.S; ++s) {
          aL += sample(lf.views, lf, t, s, y, x);
          a += sample(lf.weights, lf, t, s, y, x);
        }
      ASSERT_NEAR(slice.at<float>(y, x), a > 0 ? aL / a : 0.0, 1e-6) << x << ", " << y;
    }
}

TEST(FocalStack, AlphaSliceAtFractionalSlopesWeighsEveryTapByAlpha) {
  const LightField lf = alphaLightField(4, 3, 37, 29);
  const std::vector<double> slopes{-1.3, 0.4, 2.2};
  const std::vector<cv::Mat> slices = render(lf, slopes);
  for (size_t k = 0; k < slopes.size(); ++k)
    EXPECT_LT(maxDifference(slices[k], referenceSlice(lf, slopes[k])), 1e-5)
        << "slope " << slopes[k];
}

TEST(FocalStack, PixelThatNoValidSampleReachesIsZero) {
  LightField lf = alphaLightField(3, 3, 18, 20);
  // Alpha 0 in rows 6..9 of every view: at slope 0 nothing valid reaches them.
  for (int t = 0; t < lf.T; ++t)
    for (int s = 0; s < lf.S; ++s)
      for (int v = 6; v < 10; ++v)
        for (int u = 0; u < lf.U; ++u) {
          sample(lf.weights, lf, t, s, v, u) = 0.f;
          sample(lf.views, lf, t, s, v, u) = 0.f;
        }
  const cv::Mat slice = render(lf, {0.0})[0];
  EXPECT_EQ(cv::countNonZero(slice.rowRange(6, 10)), 0);
  EXPECT_GT(cv::countNonZero(slice.rowRange(0, 6)), 0);
}

}  // namespace
