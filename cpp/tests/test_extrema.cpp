// The extrema search (extrema.hpp) on hand-made DoG stacks: the 80-neighbour test in
// (x, y, scale, slope), the DoG derivatives, the (x, y, scale) refinement with its
// contrast and edge tests, the sub-slope parabola, and findKeypoints end to end.
#include "extrema.hpp"

#include <liff/liff.hpp>

#include <gtest/gtest.h>

#include <functional>
#include <vector>

namespace {

using liff::detail::DetectParams;
using liff::detail::ScaleSpace;
using liff::detail::SliceNeighbourhood;

// cv::SIFT's defaults: 3 layers, contrast 0.04, edge ratio 10, sigma 1.6.
constexpr int kLayers = 3;
const DetectParams kSiftParams{kLayers, 0.04, 10, 1.6};

// A one-octave scale space of `layers` layers whose DoG images (layers + 2 of `size`)
// hold D(x, y, i) and whose Gaussians are all the ramp 0.01 x (a gradient along +x, so
// orientation assignment finds one peak).
ScaleSpace dogStack(int layers, cv::Size size, const std::function<double(int, int, int)>& D) {
  ScaleSpace space;
  space.octaves = 1;
  space.layers = layers;
  for (int i = 0; i < layers + 2; ++i) {
    cv::Mat dog(size, CV_32F);
    for (int y = 0; y < size.height; ++y)
      for (int x = 0; x < size.width; ++x) dog.at<float>(y, x) = float(D(x, y, i));
    space.dogs.push_back(dog);
  }
  for (int i = 0; i < layers + 3; ++i) {
    cv::Mat ramp(size, CV_32F);
    for (int x = 0; x < size.width; ++x) ramp.col(x).setTo(0.01 * x);
    space.gaussians.push_back(ramp);
  }
  return space;
}

// A 3-D quadratic DoG  D(p) = peak + (p - p*)^T A (p - p*) / 2  in p = (x, y, i):
// gradient A (p - p*), Hessian A, extremum D(p*) = peak.
struct Quadratic {
  cv::Vec3d centre;  // p* = (x*, y*, i*)
  cv::Matx33d A;
  double peak;

  double operator()(int x, int y, int i) const {
    const cv::Vec3d d = cv::Vec3d(x, y, i) - centre;
    return peak + 0.5 * d.dot(A * d);
  }
};

// A maximum with coupled axes (every off-diagonal entry non-zero) and curvature ratio
// well inside cv::SIFT's edge limit, and the minimum of the opposite sign.
const cv::Matx33d kConcave(-0.012, 0.003, 0.002,
                           0.003, -0.010, -0.0015,
                           0.002, -0.0015, -0.008);
constexpr double kPeak = 0.05;  // contrast 0.05 * 3 layers >= 0.04

const cv::Size kOctaveSize(32, 32);

// --- DoG derivatives -----------------------------------------------------------------

TEST(DogDerivatives, CentralDifferencesOfAQuadraticAreItsExactDerivatives) {
  const Quadratic q{{16.3, 15.6, 2.2}, kConcave, kPeak};
  const ScaleSpace space = dogStack(kLayers, kOctaveSize, q);
  const cv::Vec3i at(17, 14, 1);  // (x, y, layer), off the extremum: a non-zero gradient
  const liff::detail::DogDerivatives d =
      liff::detail::dogDerivatives(space, 0, at[2], at[1], at[0]);
  const cv::Vec3d gradient = q.A * (cv::Vec3d(at[0], at[1], at[2]) - q.centre);
  EXPECT_NEAR(d.value, q(at[0], at[1], at[2]), 1e-7);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(d.gradient[k], gradient[k], 1e-6) << "d/dp" << k;
  const cv::Matx33f H = d.hessian();
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) EXPECT_NEAR(H(a, b), q.A(a, b), 1e-6) << a << ", " << b;
  // The named entries are the Hessian's, in (x, y, s) order.
  EXPECT_EQ(d.dxx, H(0, 0));
  EXPECT_EQ(d.dyy, H(1, 1));
  EXPECT_EQ(d.dss, H(2, 2));
  EXPECT_EQ(d.dxy, H(0, 1));
  EXPECT_EQ(d.dxs, H(0, 2));
  EXPECT_EQ(d.dys, H(1, 2));
}

// --- Refinement in (x, y, scale) ------------------------------------------------------------

// Refines from sample `start` (x, y, layer) and expects the sample nearest p* with the
// offsets p* - sample and the contrast `peak` (the quadratic fit is exact).
void expectRefinedTo(const Quadratic& q, cv::Vec3i start) {
  SCOPED_TRACE(testing::Message() << "p* = " << q.centre << ", start " << start);
  const ScaleSpace space = dogStack(kLayers, kOctaveSize, q);
  liff::detail::Refined e;
  ASSERT_TRUE(liff::detail::refine(space, 0, kSiftParams, start[1], start[0], start[2], e));
  EXPECT_EQ(e.c, cvRound(q.centre[0]));
  EXPECT_EQ(e.r, cvRound(q.centre[1]));
  EXPECT_EQ(e.layer, cvRound(q.centre[2]));
  EXPECT_NEAR(e.xc, q.centre[0] - e.c, 1e-4);
  EXPECT_NEAR(e.xr, q.centre[1] - e.r, 1e-4);
  EXPECT_NEAR(e.xi, q.centre[2] - e.layer, 1e-4);
  EXPECT_NEAR(e.contrast, q.peak, 1e-6);
}

const cv::Vec3d kCentres[] = {{16.3, 15.6, 2.2}, {15.55, 16.45, 1.7}, {16, 16, 2},
                              {14.9, 17.2, 2.45}};

TEST(Refinement, ConvergesToTheExtremumOfAQuadraticDoG) {
  for (const cv::Vec3d& centre : kCentres) {
    expectRefinedTo({centre, kConcave, kPeak}, {cvRound(centre[0]), cvRound(centre[1]),
                                                cvRound(centre[2])});
    expectRefinedTo({centre, -kConcave, -kPeak}, {cvRound(centre[0]), cvRound(centre[1]),
                                                  cvRound(centre[2])});  // a minimum
  }
}

TEST(Refinement, StartedOneSampleAwayMovesToTheSampleNearestTheExtremum) {
  const cv::Vec3d centre = kCentres[0];
  const cv::Vec3i nearest(cvRound(centre[0]), cvRound(centre[1]), cvRound(centre[2]));
  for (const cv::Vec3i& step : {cv::Vec3i(1, 0, 0), cv::Vec3i(0, -1, 0), cv::Vec3i(0, 0, 1),
                                cv::Vec3i(-1, 1, -1)})
    expectRefinedTo({centre, kConcave, kPeak}, nearest + step);
}

// |D(x_hat)| * layers must reach contrastThreshold: 0.0125 * 3 = 0.0375 < 0.04 fails,
// 0.0145 * 3 = 0.0435 passes.
TEST(Refinement, RejectsContrastBelowTheThresholdOnly) {
  const cv::Vec3d centre = kCentres[0];
  liff::detail::Refined e;
  for (double peak : {0.0125, 0.0145}) {
    const ScaleSpace space = dogStack(kLayers, kOctaveSize, Quadratic{centre, kConcave, peak});
    EXPECT_EQ(liff::detail::refine(space, 0, kSiftParams, 16, 16, 2, e), peak > 0.04 / kLayers)
        << "peak " << peak;
  }
}

// Principal curvatures -0.03 and -0.002 along x and y, ratio 15:
// tr^2 / det = (15 + 1)^2 / 15 = 17.07, beyond (10 + 1)^2 / 10 = 12.1 but within
// (20 + 1)^2 / 20 = 22.05. A saddle (det < 0) fails whatever the limit.
TEST(Refinement, RejectsEdgesBeyondTheCurvatureRatioAndSaddles) {
  const cv::Vec3d centre = kCentres[0];
  const cv::Matx33d ridge(-0.03, 0, 0, 0, -0.002, 0, 0, 0, -0.008);
  const cv::Matx33d saddle(-0.01, 0, 0, 0, 0.01, 0, 0, 0, -0.008);
  const ScaleSpace edge = dogStack(kLayers, kOctaveSize, Quadratic{centre, ridge, kPeak});
  const ScaleSpace cross = dogStack(kLayers, kOctaveSize, Quadratic{centre, saddle, kPeak});
  DetectParams lenient = kSiftParams;
  lenient.edgeThreshold = 20;
  liff::detail::Refined e;
  EXPECT_FALSE(liff::detail::refine(edge, 0, kSiftParams, 16, 16, 2, e));
  EXPECT_TRUE(liff::detail::refine(edge, 0, lenient, 16, 16, 2, e));
  EXPECT_FALSE(liff::detail::refine(cross, 0, lenient, 16, 16, 2, e));
}

// --- Sub-slope fit -----------------------------------------------------------------------------

// Slices k - 1, k, k + 1 whose DoG is `values` (below, here, above) everywhere.
struct ThreeSlices {
  ScaleSpace below, here, above;
  explicit ThreeSlices(cv::Vec3d values)
      : below(constantStack(values[0])), here(constantStack(values[1])),
        above(constantStack(values[2])) {}
  SliceNeighbourhood neighbourhood() const {
    SliceNeighbourhood n;
    n.below = &below;
    n.here = &here;
    n.above = &above;
    return n;
  }
  static ScaleSpace constantStack(double value) {
    return dogStack(1, cv::Size(3, 3), [value](int, int, int) { return value; });
  }
};

const liff::detail::Refined kCentreSample{1, 1, 1, 0.f, 0.f, 0.f, 0.f};

// D(k) = c - a (k - k*)^2 sampled at k = -1, 0, 1.
cv::Vec3d parabola(double a, double c, double vertex) {
  auto at = [&](double k) { return c - a * (k - vertex) * (k - vertex); };
  return cv::Vec3d(at(-1), at(0), at(1));
}

// D(k) = c exp(-a (k - k*)^2) sampled at k = -1, 0, 1: a blob's response in slope.
cv::Vec3d gaussian(double a, double c, double vertex) {
  auto at = [&](double k) { return c * std::exp(-a * (k - vertex) * (k - vertex)); };
  return cv::Vec3d(at(-1), at(0), at(1));
}

TEST(SubSlope, OffsetIsTheVertexOfAGaussianThroughTheThreeSlices) {
  for (double vertex : {-0.5, -0.3, 0.0, 0.125, 0.45})
    for (double a : {0.1, 1.0, 4.0})  // broad to sharp, where a parabola in D is far off
      for (double c : {0.05, -0.05}) {  // a maximum and a minimum of D
        const ThreeSlices slices(gaussian(a, c, vertex));
        EXPECT_NEAR(liff::detail::subSlopeOffset(slices.neighbourhood(), 0, kCentreSample),
                    vertex, 1e-4)
            << "a = " << a << ", c = " << c;
      }
}

TEST(SubSlope, WhereSignsDifferTheParabolaThroughDGivesTheVertex) {
  for (double vertex : {-0.3, 0.0, 0.2}) {
    // c - a (k - k*)^2 crossing zero within the three slices
    const ThreeSlices slices(parabola(0.05, 0.03, vertex));
    const cv::Vec3d d = parabola(0.05, 0.03, vertex);
    ASSERT_TRUE(d[0] * d[1] < 0 || d[2] * d[1] < 0);
    EXPECT_NEAR(liff::detail::subSlopeOffset(slices.neighbourhood(), 0, kCentreSample), vertex,
                1e-5);
  }
}

TEST(SubSlope, VertexBeyondHalfAStepIsClampedToHalfAStep) {
  for (double vertex : {0.8, -1.2}) {
    const ThreeSlices slices(gaussian(1.0, 0.05, vertex));
    EXPECT_EQ(liff::detail::subSlopeOffset(slices.neighbourhood(), 0, kCentreSample),
              vertex > 0 ? 0.5f : -0.5f);
  }
}

TEST(SubSlope, EndsOfTheSlopeRangeAndFlatProfilesKeepTheSliceSlope) {
  const ThreeSlices curved(parabola(0.004, 0.05, 0.3));
  SliceNeighbourhood first = curved.neighbourhood(), last = curved.neighbourhood();
  first.below = nullptr;
  last.above = nullptr;
  EXPECT_EQ(liff::detail::subSlopeOffset(first, 0, kCentreSample), 0.f);
  EXPECT_EQ(liff::detail::subSlopeOffset(last, 0, kCentreSample), 0.f);
  const ThreeSlices flat(cv::Vec3d(0.05, 0.05, 0.05));
  EXPECT_EQ(liff::detail::subSlopeOffset(flat.neighbourhood(), 0, kCentreSample), 0.f);
}

// --- The 80-neighbour test ----------------------------------------------------------------------

// Three slices of 16 x 16 DoGs filled with `around`, with the sample under test, `value`,
// at (kX, kY) of layer kLayer of the middle slice.
constexpr int kX = 8, kY = 7, kLayer = 2;

struct Neighbourhood80 {
  ScaleSpace slice[3];  // below, here, above
  Neighbourhood80(float value, float around) {
    for (ScaleSpace& s : slice)
      s = dogStack(kLayers, cv::Size(16, 16), [around](int, int, int) { return around; });
    at(1, 0, 0, 0) = value;
  }
  // The DoG sample at offset (dk, di, dy, dx) in (slope, scale, y, x) from the centre.
  float& at(int k, int di, int dy, int dx) {
    return slice[k].dogs[kLayer + di].at<float>(kY + dy, kX + dx);
  }
  bool isExtremum(bool hasBelow = true, bool hasAbove = true) const {
    SliceNeighbourhood n;
    n.below = hasBelow ? &slice[0] : nullptr;
    n.here = &slice[1];
    n.above = hasAbove ? &slice[2] : nullptr;
    const float v = slice[1].dog(0, kLayer).at<float>(kY, kX);
    return liff::detail::isExtremum(n, 0, kLayer, kY, kX, v);
  }
};

// Calls fn(k, di, dy, dx) for each of the 80 neighbours: 26 in the middle slice (k = 1),
// 27 in each of the slices below (k = 0) and above (k = 2).
void forEach80(const std::function<void(int, int, int, int)>& fn) {
  for (int k = 0; k < 3; ++k)
    for (int di = -1; di <= 1; ++di)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          if (k != 1 || di != 0 || dy != 0 || dx != 0) fn(k, di, dy, dx);
}

TEST(EightyNeighbours, SampleBeyondAll80NeighboursIsAnExtremum) {
  EXPECT_TRUE(Neighbourhood80(0.1f, 0.05f).isExtremum());    // maximum
  EXPECT_TRUE(Neighbourhood80(-0.1f, -0.05f).isExtremum());  // minimum
  EXPECT_FALSE(Neighbourhood80(0.1f, 0.2f).isExtremum());    // a positive minimum is not
}

TEST(EightyNeighbours, LosingToAnySingleNeighbourRejects) {
  int neighbours = 0;
  for (float sign : {1.f, -1.f})
    forEach80([&](int k, int di, int dy, int dx) {
      Neighbourhood80 n(sign * 0.1f, sign * 0.05f);
      n.at(k, di, dy, dx) = sign * 0.1001f;
      EXPECT_FALSE(n.isExtremum()) << "sign " << sign << ", neighbour (slice " << k - 1
                                   << ", layer " << di << ", y " << dy << ", x " << dx << ")";
      neighbours += sign > 0;
    });
  EXPECT_EQ(neighbours, 80);
}

TEST(EightyNeighbours, SamplesBeyondTheNeighbourhoodDoNotCount) {
  Neighbourhood80 n(0.1f, 0.05f);
  n.at(0, 0, 2, 0) = n.at(2, 0, 0, -2) = n.at(1, 0, 0, 2) = 1.f;  // two samples away
  n.slice[1].dogs[kLayer + 2].at<float>(kY, kX) = 1.f;          // two layers away
  EXPECT_TRUE(n.isExtremum());
}

// cv::SIFT compares with >= (<= for minima): a sample equal to a neighbour, or to all of
// them, is still an extremum.
TEST(EightyNeighbours, TiesPassAsInSift) {
  for (float sign : {1.f, -1.f}) {
    Neighbourhood80 n(sign * 0.1f, sign * 0.05f);
    n.at(0, -1, 1, 1) = n.at(1, 0, 0, 1) = n.at(2, 1, -1, 0) = sign * 0.1f;
    EXPECT_TRUE(n.isExtremum()) << "sign " << sign;
    EXPECT_TRUE(Neighbourhood80(sign * 0.1f, sign * 0.1f).isExtremum()) << "plateau";
  }
}

// At the first slope there is no slice below, at the last none above: the test uses the
// 53 neighbours that exist (26 + 27), and still rejects a loss on the side that exists.
TEST(EightyNeighbours, FirstAndLastSlicesSkipTheMissingSide) {
  Neighbourhood80 n(0.1f, 0.05f);
  EXPECT_TRUE(n.isExtremum(false, true));
  EXPECT_TRUE(n.isExtremum(true, false));
  EXPECT_TRUE(n.isExtremum(false, false));  // a single slice: 26 neighbours, as cv::SIFT
  n.at(2, 1, 0, 0) = 0.2f;                  // the slice above beats it
  EXPECT_FALSE(n.isExtremum(false, true));
  EXPECT_TRUE(n.isExtremum(true, false));
  n.at(0, -1, 0, 0) = 0.2f;  // and the slice below
  EXPECT_FALSE(n.isExtremum(true, false));
}

// --- findKeypoints end to end -------------------------------------------------------------

// Slices at slopes 0, 0.5, 1 whose DoGs are one concave quadratic, lowered by 0.004 in
// the slice below and by 0.002 in the slice above: the middle slice's peak beats all 80
// neighbours, and the Gaussian through the three slices' values at the peak (P - 0.004,
// P, P - 0.002) peaks at (ln D- - ln D+) / (2 (ln D- - 2 ln D0 + ln D+)) steps.
struct Scene {
  static constexpr double kSlope = 0.5, kStep = 0.5, kBelow = 0.004, kAbove = 0.002;
  Quadratic q{kCentres[0], cv::Matx33d(-0.01, 0, 0, 0, -0.01, 0, 0, 0, -0.01), kPeak};
  ScaleSpace below = dogStack(kLayers, kOctaveSize, shifted(-kBelow));
  ScaleSpace here = dogStack(kLayers, kOctaveSize, q);
  ScaleSpace above = dogStack(kLayers, kOctaveSize, shifted(-kAbove));

  std::function<double(int, int, int)> shifted(double by) const {
    const Quadratic copy = q;
    return [copy, by](int x, int y, int i) { return copy(x, y, i) + by; };
  }
  std::vector<cv::KeyPoint> find(bool hasBelow = true, bool hasAbove = true) const {
    SliceNeighbourhood n;
    n.below = hasBelow ? &below : nullptr;
    n.here = &here;
    n.above = hasAbove ? &above : nullptr;
    n.slope = kSlope;
    n.slopeStep = kStep;
    std::vector<cv::KeyPoint> found;
    for (const liff::detail::SearchTask& task : liff::detail::searchTasks(here, 8)) {
      const std::vector<cv::KeyPoint> part =
          liff::detail::findKeypoints(n, kSiftParams, cv::Mat(), task);
      found.insert(found.end(), part.begin(), part.end());
    }
    return found;
  }
};

TEST(FindKeypoints, ExtremumBeatingAll80NeighboursIsFoundAtItsRefinedPositionAndSlope) {
  const Scene scene;
  const cv::Vec3d p = scene.q.centre;
  // Octave 0 is the 2x upsampled view: octave pixel X is view pixel X / 2 - 1/4.
  const cv::Point2f view(float(p[0] / 2 - 0.25), float(p[1] / 2 - 0.25));
  const double lm = std::log(kPeak - Scene::kBelow), l0 = std::log(kPeak),
               lp = std::log(kPeak - Scene::kAbove);
  const double subSlope = (lm - lp) / (2 * (lm - 2 * l0 + lp));
  struct Case {
    bool below, above;
    double slope;
  };
  for (const Case& c : {Case{true, true, Scene::kSlope + subSlope * Scene::kStep},
                        Case{false, true, Scene::kSlope}, Case{true, false, Scene::kSlope}}) {
    SCOPED_TRACE(testing::Message() << "below " << c.below << ", above " << c.above);
    const std::vector<cv::KeyPoint> found = scene.find(c.below, c.above);
    ASSERT_EQ(found.size(), 1u);
    EXPECT_NEAR(found[0].pt.x, view.x, 1e-4);
    EXPECT_NEAR(found[0].pt.y, view.y, 1e-4);
    EXPECT_NEAR(found[0].response, kPeak, 1e-6);
    EXPECT_NEAR(liff::keypointSlope(found[0]), c.slope, 1e-4);
  }
}

// The cheap pre-test (|D| over the threshold, >= its four horizontal and vertical
// neighbours) lets ties through, as the full test does: a peak whose sample equals one of
// those neighbours is still found, a maximum and (every DoG negated) a minimum alike.
TEST(FindKeypoints, ExtremumTyingWithAnyOfItsFourNeighboursIsFoundMaximumOrMinimum) {
  const cv::Point offsets[] = {{-1, 0}, {1, 0}, {0, -1}, {0, 1}};
  for (bool minimum : {false, true})
    for (const cv::Point& d : offsets) {
      SCOPED_TRACE(testing::Message() << (minimum ? "minimum" : "maximum") << ", tie at " << d);
      Scene scene;
      if (minimum)
        for (ScaleSpace* space : {&scene.below, &scene.here, &scene.above})
          for (cv::Mat& dog : space->dogs) dog *= -1;
      const cv::Vec3d p = scene.q.centre;
      cv::Mat& dog = scene.here.dogs[cvRound(p[2])];
      const int r = cvRound(p[1]), c = cvRound(p[0]);
      dog.at<float>(r + d.y, c + d.x) = dog.at<float>(r, c);
      EXPECT_FALSE(scene.find().empty());
    }
}

TEST(FindKeypoints, ExtremumLosingToOneNeighbourInTheSliceAboveOrBelowIsNotFound) {
  for (bool raiseAbove : {true, false}) {
    Scene scene;
    ScaleSpace& side = raiseAbove ? scene.above : scene.below;
    const cv::Vec3d p = scene.q.centre;
    // One diagonal neighbour of the peak's sample, just above the peak.
    side.dogs[cvRound(p[2]) + 1].at<float>(cvRound(p[1]) - 1, cvRound(p[0]) + 1) =
        float(kPeak + 0.001);
    EXPECT_TRUE(scene.find().empty()) << (raiseAbove ? "slice above" : "slice below");
  }
}

}  // namespace
