// The plane sweep of the automatic slope range (slope_sweep.hpp): textured layers are
// found at their slopes; flat, noisy or undetectable light fields vote for nothing.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <algorithm>
#include <vector>

#include "slope_sweep.hpp"

namespace {

using liff::detail::LightField;
using liff::detail::SlopeIntervals;
using liff::detail::sweepSlopes;

constexpr int kSide = 96;
/// LiFF's pre-test threshold with the default parameters (0.5 * 0.04 / 3).
constexpr float kMinResponse = 0.5f * 0.04f / 3;

// Smoothed uniform noise in [0, 1] (blur `sigma` px), reproducible from `seed`.
cv::Mat texture(int side, double sigma, int seed) {
  cv::Mat noise(side, side, CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0.f, 1.f);
  cv::GaussianBlur(noise, noise, cv::Size(), sigma);
  cv::normalize(noise, noise, 0, 1, cv::NORM_MINMAX);
  return noise;
}

// T x S views of `slopes.size()` vertical strips of `scene`, strip i at slopes[i]: view
// (t, s) shows at x what the centre view shows at x + m (s - S / 2) (HCI disparity sign).
LightField stripes(int T, int S, const std::vector<double>& slopes, double sigma = 1.5) {
  LightField lf;
  lf.T = T;
  lf.S = S;
  lf.V = lf.U = kSide;
  lf.allocate(false);
  const cv::Mat scene = texture(kSide, sigma, 7);
  for (int t = 0; t < T; ++t)
    for (int s = 0; s < S; ++s) {
      cv::Mat& view = lf.views[size_t(t) * S + s];
      for (size_t i = 0; i < slopes.size(); ++i) {
        const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, slopes[i] * (s - S / 2), 0, 1,
                               slopes[i] * (t - T / 2));
        cv::Mat warped;
        cv::warpAffine(scene, warped, shift, scene.size(),
                       cv::INTER_CUBIC | cv::WARP_INVERSE_MAP, cv::BORDER_REFLECT);
        const int x0 = int(i) * kSide / int(slopes.size()), x1 = int(i + 1) * kSide / int(slopes.size());
        warped.colRange(x0, x1).copyTo(view.colRange(x0, x1));
      }
    }
  return lf;
}

// The sweep's intervals with LiFF's default thresholds (pre-test and detection), or
// `minResponse` for both.
SlopeIntervals swept(const LightField& lf, double lo, double hi,
                     float minResponse = kMinResponse) {
  const float detection = minResponse == kMinResponse ? 2 * kMinResponse : minResponse;
  return sweepSlopes(lf, lo, hi, minResponse, detection).intervals;
}

bool covered(const SlopeIntervals& found, double slope) {
  for (const auto& [a, b] : found)
    if (slope >= a - 1e-9 && slope <= b + 1e-9) return true;
  return false;
}

TEST(SlopeSweep, FindsEachTexturedLayerAndNothingBetween) {
  const std::vector<double> slopes{-3.0, 0.25, 2.5};
  const SlopeIntervals found = swept(stripes(5, 5, slopes), -8, 8);
  for (double m : slopes) EXPECT_TRUE(covered(found, m)) << "layer at " << m;
  for (double m : {-1.5, 1.25, 5.0}) EXPECT_FALSE(covered(found, m)) << "nothing at " << m;
  for (const auto& [a, b] : found) EXPECT_LE(b - a, 0.5 + 1e-9);  // a few half-pixel steps
}

TEST(SlopeSweep, FindsFineTexturesHalfWayBetweenWholePixelShifts) {
  // 1.5 px of parallax per view step: whole-pixel shifts miss a 1 px texture by half a pixel.
  const SlopeIntervals found = swept(stripes(3, 3, {1.5}, 0.8), -6, 6);
  EXPECT_TRUE(covered(found, 1.5));
}

TEST(SlopeSweep, WorksOnARowOrAColumnOfViews) {
  for (const auto& [T, S] : {std::pair{1, 7}, std::pair{7, 1}, std::pair{3, 6}}) {
    const SlopeIntervals found = swept(stripes(T, S, {-1.0}), -4, 4);
    EXPECT_TRUE(covered(found, -1.0)) << T << "x" << S;
  }
}

TEST(SlopeSweep, FlatNoisyOrFaintLightFieldsVoteForNothing) {
  LightField flat = stripes(5, 5, {0.0});
  for (cv::Mat& view : flat.views) view.setTo(0.5);
  EXPECT_TRUE(swept(flat, -8, 8).empty());
  LightField noise = flat;
  cv::RNG rng(3);
  for (cv::Mat& view : noise.views) {
    cv::Mat n(view.size(), CV_32F);
    rng.fill(n, cv::RNG::NORMAL, 0.f, 0.01f);
    view = view + n;  // a new Mat (flat's views stay flat); independent per view
  }
  EXPECT_TRUE(swept(noise, -8, 8).empty());
  // A texture too faint for LiFF's contrast threshold is not structure LiFF can use.
  LightField faint = stripes(5, 5, {1.0});
  for (cv::Mat& view : faint.views) view = 0.5 + 0.01 * (view - 0.5);
  EXPECT_TRUE(swept(faint, -8, 8).empty());
  EXPECT_TRUE(covered(swept(faint, -8, 8, 0.f), 1.0));  // contrastThreshold 0: found
}

TEST(SlopeSweep, OnlySweepsTheSlopesAsked) {
  const SlopeIntervals found = swept(stripes(5, 5, {-3.0, 2.5}), 0, 8);
  EXPECT_TRUE(covered(found, 2.5));
  for (const auto& [a, b] : found) EXPECT_GE(a, -0.25 - 1e-9);
  EXPECT_TRUE(swept(stripes(5, 5, {1.0}), 2, 1).empty());  // empty range
  // A layer beyond the range votes for the slope nearest it, which is not taken as one.
  EXPECT_TRUE(swept(stripes(5, 5, {-3.0}), -2.3, 8).empty());
  EXPECT_TRUE(covered(swept(stripes(5, 5, {-2.25}), -2.3, 8), -2.25));
}

// T x S views of `side` pixels: a flat 0.5 with a disk of radius `radius` and contrast
// 0.3 at (cx, cy) of the centre view, at `slope` (anti-aliased edge), and faint noise.
LightField disk(int T, int S, int side, double cx, double cy, double radius, double slope) {
  LightField lf;
  lf.T = T;
  lf.S = S;
  lf.V = lf.U = side;
  lf.allocate(false);
  cv::RNG rng(3);
  for (int t = 0; t < T; ++t)
    for (int s = 0; s < S; ++s) {
      cv::Mat& view = lf.views[size_t(t) * S + s];
      const double x0 = cx - slope * (s - S / 2), y0 = cy - slope * (t - T / 2);
      for (int y = 0; y < side; ++y)
        for (int x = 0; x < side; ++x) {
          const double cover = std::min(1.0, std::max(0.0, radius + 0.5 - std::hypot(x - x0, y - y0)));
          view.at<float>(y, x) = float(0.5 + 0.3 * cover + rng.gaussian(0.01));
        }
    }
  return lf;
}

TEST(SlopeSweep, FindsASmallIsolatedFeatureAndSaysWhenStructureLiesBeyondTheRange) {
  // A disk of radius 3 in a 256 x 256 view: its votes are far under 0.5% of the view
  // (328 pixels), but they gather in one place.
  const LightField lf = disk(5, 5, 256, 128.3, 100.6, 3.0, 1.5);
  const auto within = sweepSlopes(lf, -4, 4, kMinResponse, 2 * kMinResponse);
  EXPECT_TRUE(covered(within.intervals, 1.5));
  EXPECT_FALSE(within.beyondLow || within.beyondHigh);
  for (const auto& [a, b] : within.intervals) EXPECT_NEAR(0.5 * (a + b), 1.5, 0.5);
  // The range ends short of it: the slope swept beyond the end (1.5) sees it, reported
  // apart from the intervals.
  const auto cut = sweepSlopes(lf, -1, 1.45, kMinResponse, 2 * kMinResponse);
  EXPECT_FALSE(covered(cut.intervals, 1.5));
  EXPECT_TRUE(cut.beyondHigh);
  EXPECT_FALSE(cut.beyondLow);
  // Under LiFF's detection threshold (contrast 0.3 over a threshold of 1): not a feature.
  EXPECT_TRUE(sweepSlopes(lf, -4, 4, kMinResponse, 1.f).intervals.empty());
}

TEST(SlopeSweep, IgnoresSamplesWhoseAlphaIsLow) {
  LightField lf = stripes(5, 5, {1.0});
  // The left half of every view invalid (weight 0, premultiplied value 0): still found
  // from the right half, and no NaN escapes into the result.
  for (cv::Mat& view : lf.views) {
    cv::Mat weight(view.size(), CV_32F, cv::Scalar(1));
    weight.colRange(0, kSide / 2).setTo(0);
    view.colRange(0, kSide / 2).setTo(0);
    lf.weights.push_back(weight);
  }
  const SlopeIntervals found = swept(lf, -8, 8);
  EXPECT_TRUE(covered(found, 1.0));
  for (const auto& [a, b] : found) EXPECT_LE(b - a, 1.0);
}

}  // namespace

// The survey decimates twice in one pass, keeping of the first decimation only the views
// the sweep reads (its row and column): the same values as two whole decimations.
TEST(SlopeSweep, DecimatingTwiceInOnePassKeepsTheSweptViewsAndGivesTheSameLevels) {
  for (bool weighted : {false, true}) {
    liff::detail::LightField lf;
    lf.T = 3;
    lf.S = 5;
    lf.V = 37;
    lf.U = 50;
    lf.allocate(weighted);
    for (cv::Mat& view : lf.views) cv::randu(view, 0.f, 1.f);
    for (cv::Mat& weight : lf.weights) cv::randu(weight, 0.f, 1.f);
    const std::vector<bool> keep = liff::detail::sweptViews(lf.T, lf.S);
    liff::detail::LightField once, twice;
    liff::detail::decimateTwice(lf, 2, 2, keep, once, twice);
    const liff::detail::LightField a = liff::detail::decimate(lf, 2);
    const liff::detail::LightField b = liff::detail::decimate(a, 2);
    ASSERT_EQ(twice.V, b.V);
    ASSERT_EQ(twice.U, b.U);
    for (size_t v = 0; v < lf.views.size(); ++v) {
      EXPECT_EQ(cv::norm(twice.views[v], b.views[v], cv::NORM_INF), 0);
      if (weighted) EXPECT_EQ(cv::norm(twice.weights[v], b.weights[v], cv::NORM_INF), 0);
      EXPECT_EQ(once.views[v].empty(), !keep[v]);
      if (keep[v]) EXPECT_EQ(cv::norm(once.views[v], a.views[v], cv::NORM_INF), 0);
    }
    EXPECT_EQ(std::count(keep.begin(), keep.end(), true), lf.T + lf.S - 1);
  }
}
