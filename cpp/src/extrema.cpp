#include "extrema.hpp"

#include "descriptor.hpp"
#include "hot_loop.hpp"
#include "profile.hpp"

#include <liff/liff.hpp>

#include <algorithm>
#include <array>
#include <cfloat>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <cstdlib>

namespace liff {
namespace detail {
namespace {

/// Newton steps allowed for the (x, y, scale) refinement before giving up.
constexpr int kMaxRefineSteps = 5;

// True if v is >= (for maxima; <= for minima) all nine samples of the 3x3 patch of
// `dog` centred at (r, c), skipping the centre if asked. Ties pass, as in cv::SIFT:
// a blob centred between two pixels has two equal samples, and a strict test would
// lose it; the two refine to the same point and one is dropped as a duplicate.
inline bool beats3x3(float v, bool isMax, const cv::Mat& dog, int r, int c, bool skipCentre) {
  for (int dr = -1; dr <= 1; ++dr) {
    const float* row = dog.ptr<float>(r + dr);
    for (int dc = -1; dc <= 1; ++dc) {
      if (skipCentre && dr == 0 && dc == 0) continue;
      const float n = row[c + dc];
      if (isMax ? !(v >= n) : !(v <= n)) return false;
    }
  }
  return true;
}

// Marks the columns of DoG row `row` that pass the cheapest tests: |v| above the
// pre-threshold and >= (<= for minima) its four horizontal and vertical neighbours
// (`up`, `down`: the rows above and below), i.e. >= the largest of them (<= the
// smallest; DoG values are finite). Branch-free, so it vectorises, in AVX-512 where the
// CPU has it (comparisons only: every build marks alike); the full test repeats these
// comparisons, so the pre-test only saves work.
LIFF_COMPARE_LOOP void markCandidates(const float* up, const float* row, const float* down,
                                      int begin, int end, float threshold, uchar* candidate) {
  for (int c = begin; c < end; ++c) {
    const float v = row[c], left = row[c - 1], right = row[c + 1], above = up[c],
                below = down[c];
    const float highest = std::max(std::max(left, right), std::max(above, below));
    const float lowest = std::min(std::min(left, right), std::min(above, below));
    candidate[c] =
        uchar((v > threshold) & (v >= highest)) | uchar((v < -threshold) & (v <= lowest));
  }
}

}  // namespace

// The own layer goes first: it rejects most candidates.
bool isExtremum(const SliceNeighbourhood& slices, int o, int i, int r, int c, float v) {
  const bool isMax = v > 0;
  if (!beats3x3(v, isMax, slices.here->dog(o, i), r, c, true)) return false;
  for (int di : {-1, 1})
    if (!beats3x3(v, isMax, slices.here->dog(o, i + di), r, c, false)) return false;
  for (const ScaleSpace* side : {slices.below, slices.above}) {
    if (!side) continue;
    for (int di = -1; di <= 1; ++di)
      if (!beats3x3(v, isMax, side->dog(o, i + di), r, c, false)) return false;
  }
  return true;
}

// The stencils of DogDerivatives (extrema.hpp), written as cv::SIFT writes them:
// second differences as D(+1) + D(-1) - 2 D, the factors 1/2 and 1/4 applied last.
DogDerivatives dogDerivatives(const ScaleSpace& space, int o, int layer, int r, int c) {
  const cv::Mat& img = space.dog(o, layer);
  const cv::Mat& prev = space.dog(o, layer - 1);
  const cv::Mat& next = space.dog(o, layer + 1);
  DogDerivatives d{};
  d.value = img.at<float>(r, c);
  const float v2 = 2.f * d.value;
  d.gradient = cv::Vec3f((img.at<float>(r, c + 1) - img.at<float>(r, c - 1)) * 0.5f,
                         (img.at<float>(r + 1, c) - img.at<float>(r - 1, c)) * 0.5f,
                         (next.at<float>(r, c) - prev.at<float>(r, c)) * 0.5f);
  d.dxx = img.at<float>(r, c + 1) + img.at<float>(r, c - 1) - v2;
  d.dyy = img.at<float>(r + 1, c) + img.at<float>(r - 1, c) - v2;
  d.dss = next.at<float>(r, c) + prev.at<float>(r, c) - v2;
  d.dxy = (img.at<float>(r + 1, c + 1) - img.at<float>(r + 1, c - 1) -
           img.at<float>(r - 1, c + 1) + img.at<float>(r - 1, c - 1)) * 0.25f;
  d.dxs = (next.at<float>(r, c + 1) - next.at<float>(r, c - 1) -
           prev.at<float>(r, c + 1) + prev.at<float>(r, c - 1)) * 0.25f;
  d.dys = (next.at<float>(r + 1, c) - next.at<float>(r - 1, c) -
           prev.at<float>(r + 1, c) + prev.at<float>(r - 1, c)) * 0.25f;
  return d;
}

bool refine(const ScaleSpace& space, int o, const DetectParams& params, int r, int c, int layer,
            Refined& out) {
  const int layers = space.layers;
  const cv::Mat& base = space.dog(o, 0);
  float xi = 0, xr = 0, xc = 0;
  std::array<cv::Vec3i, kMaxRefineSteps + 1> visited;  // (r, c, layer) of each step
  visited[0] = cv::Vec3i(r, c, layer);
  // Derivatives at the current sample; every exit from the loop that keeps the point
  // leaves them at the sample it ends on, for the contrast and edge tests.
  DogDerivatives d{};
  int step = 0;
  for (; step < kMaxRefineSteps; ++step) {
    d = dogDerivatives(space, o, layer, r, c);
    const cv::Vec3f x = d.hessian().solve(d.gradient, cv::DECOMP_LU);
    xc = -x[0];
    xr = -x[1];
    xi = -x[2];
    if (std::abs(xi) < 0.5f && std::abs(xr) < 0.5f && std::abs(xc) < 0.5f) break;
    if (!(std::abs(xi) < float(INT_MAX / 3) && std::abs(xr) < float(INT_MAX / 3) &&
          std::abs(xc) < float(INT_MAX / 3)))
      return false;  // singular or NaN fit
    // A move back to a sample already visited would cycle until the step limit and
    // lose the point (cv::SIFT does): this happens at flat-topped extrema, e.g. a
    // large uniform disk at its best scale, where the quadratic fit overshoots from
    // both sides. The extremum then lies between the two samples: keep this one with
    // its fitted offset when that stays within one sample.
    const cv::Vec3i target(r + cvRound(xr), c + cvRound(xc), layer + cvRound(xi));
    const auto seen = visited.begin() + step + 1;  // the start and every move so far
    if (std::find(visited.begin(), seen, target) != seen) {
      if (!(std::abs(xi) < 1.f && std::abs(xr) < 1.f && std::abs(xc) < 1.f)) return false;
      // The position keeps its offset (up to a sample); the scale offset is held to
      // half a layer, the range cv::SIFT's octave packing (and the layer) can carry.
      xi = std::min(0.5f, std::max(-0.5f, xi));
      break;
    }
    visited[step + 1] = target;
    r = target[0];
    c = target[1];
    layer = target[2];
    if (layer < 1 || layer > layers || c < kImageBorder || c >= base.cols - kImageBorder ||
        r < kImageBorder || r >= base.rows - kImageBorder)
      return false;
  }
  if (step >= kMaxRefineSteps) return false;

  const float contrast = d.value + d.gradient.dot(cv::Vec3f(xc, xr, xi)) * 0.5f;
  if (std::abs(contrast) * layers < params.contrastThreshold) return false;

  // Edges: the principal curvatures of the 2-D Hessian [dxx dxy; dxy dyy] must have
  // one sign (det > 0) and a ratio below e = edgeThreshold: tr^2 / det < (e + 1)^2 / e.
  const float trace = d.dxx + d.dyy, det = d.dxx * d.dyy - d.dxy * d.dxy;
  const double edge = params.edgeThreshold;
  if (det <= 0 || trace * trace * edge >= (edge + 1) * (edge + 1) * det) return false;

  out = Refined{r, c, layer, xr, xc, xi, contrast};
  return true;
}

float subSlopeOffset(const SliceNeighbourhood& slices, int o, const Refined& e) {
  if (!slices.below || !slices.above) return 0.f;
  // Each slice's DoG at the refined sub-pixel position and scale x_hat, from its own
  // quadratic model: D(x_hat) = D + g . x_hat + x_hat' H x_hat / 2.
  const cv::Vec3f x(e.xc, e.xr, e.xi);
  auto at = [&](const ScaleSpace* space) {
    const DogDerivatives d = dogDerivatives(*space, o, e.layer, e.r, e.c);
    return d.value + d.gradient.dot(x) + 0.5f * x.dot(d.hessian() * x);
  };
  const float dm = at(slices.below), d0 = at(slices.here), dp = at(slices.above);
  // A blob's response falls off about as a Gaussian in the slope error (its defocus is
  // a sum of shifted copies), so fit the parabola to log |D|: exact for a Gaussian.
  if (dm * d0 > 0 && dp * d0 > 0) {
    const float lm = std::log(std::abs(dm)), l0 = std::log(std::abs(d0)),
                lp = std::log(std::abs(dp));
    const float curvature = lm - 2.f * l0 + lp;
    if (curvature < -1e-12f) return std::min(0.5f, std::max(-0.5f, 0.5f * (lm - lp) / curvature));
  }
  // Signs differ (or no peak in log |D|): the parabola through D itself.
  const float curvature = dm - 2.f * d0 + dp;
  if (!(std::abs(curvature) > 1e-12f)) return 0.f;
  return std::min(0.5f, std::max(-0.5f, 0.5f * (dm - dp) / curvature));
}

bool unpackOctave(const cv::KeyPoint& keypoint, int octaves, int layers, int firstOctave, int& o,
                  int& layer) {
  int packed = keypoint.octave & 255;
  packed = packed < 128 ? packed : (-128 | packed);  // sign-extend the low byte
  layer = (keypoint.octave >> 8) & 255;
  o = packed - firstOctave;
  return o >= 0 && o < octaves && layer >= 0 && layer <= layers + 2;
}

std::vector<SearchTask> searchTasks(const ScaleSpace& space, int rowsPerTask) {
  std::vector<SearchTask> tasks;
  for (int o = 0; o < space.octaves; ++o) {
    const int rows = space.dog(o, 0).rows;
    for (int i = 1; i <= space.layers; ++i)
      for (int r = kImageBorder; r < rows - kImageBorder; r += rowsPerTask)
        tasks.push_back({o, i, r, std::min(rows - kImageBorder, r + rowsPerTask)});
  }
  return tasks;
}

std::vector<cv::KeyPoint> findKeypoints(const SliceNeighbourhood& slices,
                                        const DetectParams& params, const cv::Mat& mask,
                                        const SearchTask& task) {
  const ScaleSpace& space = *slices.here;
  const int layers = params.layers, o = task.o, i = task.layer;
  // Cheap pre-test on |D| before the 80-neighbour comparison.
  const float preThreshold = float(kPreThresholdShare * params.contrastThreshold / layers);
  std::vector<cv::KeyPoint> keypoints;
  float hist[kOrientationBins];

  const cv::Mat& dog = space.dog(o, i);
  const int cols = dog.cols;
  // The full test of one column of row r: 80 neighbours, refinement, orientations.
  int r = 0;
  const float* row = nullptr;
  auto searchColumn = [&](int c) {
    const float v = row[c];
    if (!isExtremum(slices, o, i, r, c, v)) return;
    StageTimer timer(kRefinement);  // refinement and orientations
    Refined e;
    if (!refine(space, o, params, r, c, i, e)) return;

    cv::KeyPoint kp;
    const int first = space.firstOctave;
    kp.pt = cv::Point2f(octaveToView(e.c + e.xc, o, first), octaveToView(e.r + e.xr, o, first));
    if (!mask.empty()) {
      const int mx = cvRound(kp.pt.x), my = cvRound(kp.pt.y);
      if (mx < 0 || my < 0 || mx >= mask.cols || my >= mask.rows ||
          mask.at<uchar>(my, mx) == 0)
        return;
    }
    kp.octave = ((o + first) & 255) + (e.layer << 8) +
                (cvRound((e.xi + 0.5) * 255) << 16);
    // Diameter: 2 sigma in view pixels.
    const float octaveSigma = float(params.sigma * std::pow(2.0, (e.layer + e.xi) / layers));
    kp.size = octaveSigma * std::ldexp(1.f, o + first) * 2.f;
    kp.response = std::abs(e.contrast);
    const double slope = slices.slope + subSlopeOffset(slices, o, e) * slices.slopeStep;
    kp.class_id = slopeToClassId(slope);

    // Orientations: every histogram peak within 80% of the highest.
    const float highest = orientationHistogram(
        space.gaussian(o, e.layer), cv::Point(e.c, e.r),
        cvRound(kOrientationRadius * octaveSigma), kOrientationSigmaFactor * octaveSigma,
        hist);
    const float threshold = highest * kOrientationPeakRatio;
    const int n = kOrientationBins;
    for (int j = 0; j < n; ++j) {
      const int left = j > 0 ? j - 1 : n - 1, right = j < n - 1 ? j + 1 : 0;
      if (hist[j] > hist[left] && hist[j] > hist[right] && hist[j] >= threshold) {
        // Parabolic peak interpolation between neighbouring bins.
        float bin = j + 0.5f * (hist[left] - hist[right]) /
                            (hist[left] - 2 * hist[j] + hist[right]);
        bin = bin < 0 ? n + bin : bin >= n ? bin - n : bin;
        // The histogram's angles run counter-clockwise on screen (y up); the
        // keypoint's, as cv::SIFT's, clockwise on screen (image coordinates, y down).
        kp.angle = 360.f - (360.f / n) * bin;
        if (std::abs(kp.angle - 360.f) < FLT_EPSILON) kp.angle = 0.f;
        keypoints.push_back(kp);
      }
    }
  };
  const int cEnd = cols - kImageBorder;
  // Padded to whole 8-byte words, which are skipped at once when all zero (most are).
  std::vector<uchar> candidate(size_t(cols + 8), 0);
  for (r = task.rowBegin; r < task.rowEnd; ++r) {
    row = dog.ptr<float>(r);
    // Cheapest tests first; only columns that pass get the full test.
    markCandidates(dog.ptr<float>(r - 1), row, dog.ptr<float>(r + 1), kImageBorder, cEnd,
                   preThreshold, candidate.data());
    for (int c0 = kImageBorder; c0 < cEnd; c0 += 8) {
      uint64_t word;
      std::memcpy(&word, candidate.data() + c0, sizeof(word));
      if (word == 0) continue;
      for (int c = c0; c < std::min(cEnd, c0 + 8); ++c)
        if (candidate[c]) searchColumn(c);
    }
  }
  return keypoints;
}

}  // namespace detail
}  // namespace liff
