// Sizes of one focal slice's scale space (scale_space.hpp), as cv::SIFT sizes its
// pyramid: the slice upsampled 2x (first octave -1), halved per octave, with
// nOctaveLayers + 3 Gaussians and nOctaveLayers + 2 DoGs per octave.
#include "scale_space.hpp"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "blur.hpp"

namespace {

using liff::detail::buildScaleSpace;
using liff::detail::numOctaves;
using liff::detail::ScaleSpace;

// numOctaves = round(log2(2 min(width, height)) - 2) + 1 (cv::SIFT's count for first
// octave -1): the smallest octave image keeps a side of about 4 to 8 pixels.
TEST(ScaleSpaceSize, OctaveCountFollowsTheShorterSideAsInSift) {
  struct Case {
    cv::Size view;
    int octaves;
  };
  const Case cases[] = {
      {{64, 64}, 6},    // log2(128) - 2 = 5
      {{160, 160}, 7},  // log2(320) - 2 = 6.32
      {{180, 200}, 7},  // the shorter side counts: log2(360) - 2 = 6.49
      {{512, 512}, 9},  // log2(1024) - 2 = 8
      {{640, 48}, 6},   // log2(96) - 2 = 4.58 -> 5
      {{12, 12}, 4},    // log2(24) - 2 = 2.58 -> 3
      {{2, 2}, 1},      // log2(4) - 2 = 0
      {{1, 1}, 0},      // log2(2) - 2 = -1: nothing to search
  };
  for (const Case& c : cases)
    EXPECT_EQ(numOctaves(c.view), c.octaves) << c.view.width << " x " << c.view.height;
}

ScaleSpace build(cv::Size view, int layers, bool detectionOnly) {
  cv::Mat slice(view, CV_32F);
  cv::randu(slice, 0.f, 1.f);
  ScaleSpace space;
  buildScaleSpace(slice, layers, 1.6, numOctaves(view), cv::Vec2d(0, 0), cv::Vec2d(0, 0),
                  detectionOnly, space);
  return space;
}

// Octave o holds images of (2 width >> o) x (2 height >> o): layers + 3 Gaussians and
// layers + 2 DoGs, each DoG the difference of the Gaussians above and below it.
TEST(ScaleSpaceSize, EveryOctaveHoldsItsGaussiansAndDoGsAtHalfTheSizeOfTheLast) {
  for (cv::Size view : {cv::Size(40, 30), cv::Size(33, 64), cv::Size(16, 16)})
    for (int layers : {1, 3, 5}) {
      SCOPED_TRACE(testing::Message() << view.width << " x " << view.height << ", " << layers
                                      << " layers");
      const ScaleSpace space = build(view, layers, false);
      ASSERT_EQ(space.octaves, numOctaves(view));
      ASSERT_EQ(space.layers, layers);
      ASSERT_EQ(space.gaussians.size(), size_t(space.octaves) * (layers + 3));
      ASSERT_EQ(space.dogs.size(), size_t(space.octaves) * (layers + 2));
      for (int o = 0; o < space.octaves; ++o) {
        const cv::Size size(2 * view.width >> o, 2 * view.height >> o);  // first octave -1
        for (int i = 0; i < layers + 3; ++i) EXPECT_EQ(space.gaussian(o, i).size(), size);
        for (int i = 0; i < layers + 2; ++i) {
          ASSERT_EQ(space.dog(o, i).size(), size);
          EXPECT_EQ(cv::norm(space.dog(o, i), space.gaussian(o, i + 1) - space.gaussian(o, i),
                             cv::NORM_INF),
                    0);
        }
      }
    }
}

// With first octave 0 the pyramid starts at the view's own size, with cv::SIFT's
// count of octaves for it, round(log2(min side) - 2), and its first Gaussian is the
// view blurred from the assumed 0.5 to sigma.
TEST(ScaleSpaceSize, FirstOctaveZeroStartsAtTheViewsSize) {
  const cv::Size view(40, 30);
  EXPECT_EQ(liff::detail::numOctaves(view, 0), 3);  // log2(30) - 2 = 2.91
  EXPECT_EQ(liff::detail::numOctaves(cv::Size(512, 512), 0), 7);
  cv::Mat slice(view, CV_32F);
  cv::randu(slice, 0.f, 1.f);
  ScaleSpace space;
  buildScaleSpace(slice, 3, 1.6, numOctaves(view, 0), cv::Vec2d(0, 0), cv::Vec2d(0, 0), false,
                  space, nullptr, 0);
  ASSERT_EQ(space.octaves, numOctaves(view, 0));
  for (int o = 0; o < space.octaves; ++o)
    EXPECT_EQ(space.gaussian(o, 0).size(), cv::Size(view.width >> o, view.height >> o));
  cv::Mat expected;
  cv::GaussianBlur(slice, expected, cv::Size(), std::sqrt(1.6 * 1.6 - 0.25));
  EXPECT_LE(cv::norm(space.gaussian(0, 0), expected, cv::NORM_INF), 2e-6);
}

// Detection needs the DoGs and, for orientations, Gaussians 1 .. layers only.
TEST(ScaleSpaceSize, DetectionOnlyPyramidKeepsTheGaussiansKeypointsCanUse) {
  const int layers = 3;
  const ScaleSpace space = build(cv::Size(40, 30), layers, true);
  for (int o = 0; o < space.octaves; ++o) {
    for (int i = 0; i < layers + 3; ++i)
      EXPECT_EQ(space.gaussian(o, i).empty(), i == 0 || i > layers) << o << ", " << i;
    for (int i = 0; i < layers + 2; ++i) EXPECT_FALSE(space.dog(o, i).empty()) << o << ", " << i;
  }
}


// The scale space's own blur (blur.hpp) is cv::GaussianBlur's up to float rounding:
// the same taps, the same reflected borders, on every size down to 1 x 1 (kernels
// wider than the image reflect more than once).
TEST(ScaleSpaceBlur, MatchesOpenCvsGaussianBlurOnEverySize) {
  cv::RNG rng(7);
  for (cv::Size size : {cv::Size(1, 1), cv::Size(3, 2), cv::Size(5, 17), cv::Size(40, 31),
                        cv::Size(97, 64), cv::Size(8, 100)})
    for (double sigma : {0.7, 1.6, 3.1}) {
      SCOPED_TRACE(testing::Message() << size.width << " x " << size.height << ", sigma " << sigma);
      cv::Mat src(size, CV_32F), ours(size, CV_32F), expected;
      rng.fill(src, cv::RNG::UNIFORM, 0.f, 1.f);
      const liff::detail::GaussianTaps taps = liff::detail::gaussianTaps(sigma);
      liff::detail::gaussianBlurRows(src, ours, taps, taps, 0, size.height);
      cv::GaussianBlur(src, expected, cv::Size(), sigma, sigma);
      EXPECT_LE(cv::norm(ours, expected, cv::NORM_INF), 2e-6);
    }
}

// Any split into row stripes gives the same image bit for bit (stripes share no work),
// and the fused DoG is exactly the difference of the two Gaussians.
TEST(ScaleSpaceBlur, StripesGiveTheSameResultAndTheDogIsTheExactDifference) {
  cv::Mat src(53, 71, CV_32F), whole(src.size(), CV_32F), striped(src.size(), CV_32F),
      dog(src.size(), CV_32F);
  cv::randu(src, 0.f, 1.f);
  const liff::detail::GaussianTaps kx = liff::detail::gaussianTaps(1.3),
                                   ky = liff::detail::gaussianTaps(2.2);
  liff::detail::gaussianBlurRows(src, whole, kx, ky, 0, src.rows);
  for (int r0 = 0, step = 1; r0 < src.rows; r0 += step, step = step % 5 + 1)
    liff::detail::gaussianBlurRows(src, striped, kx, ky, r0, std::min(src.rows, r0 + step), &dog);
  EXPECT_EQ(cv::norm(whole, striped, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(dog, cv::Mat(whole - src), cv::NORM_INF), 0);
}

// The 2x upsample of the first octave is cv::resize(INTER_LINEAR)'s.
TEST(ScaleSpaceBlur, UpsampleMatchesOpenCvsBilinearResize) {
  for (cv::Size size : {cv::Size(1, 1), cv::Size(2, 3), cv::Size(37, 20)}) {
    cv::Mat src(size, CV_32F), ours(size * 2, CV_32F), expected;
    cv::randu(src, 0.f, 1.f);
    liff::detail::upsample2xRows(src, ours, 0, ours.rows);
    cv::resize(src, expected, cv::Size(), 2, 2, cv::INTER_LINEAR);
    EXPECT_LE(cv::norm(ours, expected, cv::NORM_INF), 1e-6) << size.width << " x " << size.height;
  }
}

}  // namespace
