// Joint extrema in (x, y, scale, slope), their sub-pixel / sub-scale / sub-slope
// refinement, contrast and edge tests, and orientation assignment.
#pragma once

#include "scale_space.hpp"

#include <opencv2/core.hpp>

#include <vector>

namespace liff {
namespace detail {

/// Detection parameters shared by all slices.
struct DetectParams {
  int layers;                // nOctaveLayers
  double contrastThreshold;  // cv::SIFT meaning: |D| >= contrastThreshold / layers
  double edgeThreshold;      // principal-curvature ratio r
  double sigma;
};

/// The focal slices around slice k: `below` (k - 1) and `above` (k + 1) are null
/// at the ends of the slope range, whose missing side is then skipped.
struct SliceNeighbourhood {
  const ScaleSpace* below = nullptr;
  const ScaleSpace* here = nullptr;
  const ScaleSpace* above = nullptr;
  double slope = 0;      // slope of slice k
  double slopeStep = 0;  // spacing of the slope grid (0 for a single slice)
};

/// One unit of the extrema search: rows [rowBegin, rowEnd) of DoG layer `layer`
/// of octave `o` of one slice. Tasks split the work evenly across threads; their
/// order (octave, layer, row) fixes the order of the keypoints.
struct SearchTask {
  int o, layer, rowBegin, rowEnd;
};

/// The search tasks of one slice's scale space, about `rowsPerTask` rows each.
std::vector<SearchTask> searchTasks(const ScaleSpace& space, int rowsPerTask);

/// Finds the keypoints of one search task of slice k: samples with |D| above half
/// the contrast threshold that are >= (maxima) or <= (minima) all 80 neighbours of
/// their 3x3x3x3 (x, y, scale, slope) neighbourhood (ties pass, as in cv::SIFT),
/// refined as SIFT in (x, y, scale) and by a parabola in slope, kept if their
/// contrast and edge tests pass and they fall inside `mask` (if not empty), with one
/// keypoint per dominant orientation. Keypoints are in centre-view pixels, octave
/// packed as cv::SIFT, class_id the slope; in (row, column, orientation peak) order.
std::vector<cv::KeyPoint> findKeypoints(const SliceNeighbourhood& slices,
                                        const DetectParams& params, const cv::Mat& mask,
                                        const SearchTask& task);

// --- The stages of findKeypoints, exposed for the tests (cpp/tests/test_extrema.cpp) ---

/// Keypoints closer than this to an octave image's border are not searched.
constexpr int kImageBorder = 5;
/// The cheap pre-test on |D| before the 80-neighbour comparison keeps samples above this
/// share of the final contrast threshold per layer (as cv::SIFT).
constexpr double kPreThresholdShare = 0.5;

/// Whether sample (r, c) of dog(o, i) of `slices.here`, of value v, is >= (v > 0:
/// maxima) or <= (minima) all 80 neighbours of its 3x3x3x3 (x, y, scale, slope)
/// neighbourhood: 26 in its own slice and 27 in each adjacent slice that exists (a
/// null `below` or `above` is skipped). Ties pass, as in cv::SIFT.
bool isExtremum(const SliceNeighbourhood& slices, int o, int i, int r, int c, float v);

/// Derivatives of one slice's DoG D(x, y, s) at a sample, by central differences over
/// the 3x3x3 samples around it, with unit steps (one octave-image pixel in x and y, one
/// layer in s), as Lowe 2004 (sec. 4) and cv::SIFT take them:
///
///   dx  = (D(x+1) - D(x-1)) / 2                                   (dy, ds alike)
///   dxx = D(x+1) + D(x-1) - 2 D                                   (dyy, dss alike)
///   dxy = (D(x+1, y+1) - D(x-1, y+1) - D(x+1, y-1) + D(x-1, y-1)) / 4
///                                                                 (dxs, dys alike)
///
/// Each is exact for a quadratic D (up to float rounding).
struct DogDerivatives {
  float value;         // D at the sample
  cv::Vec3f gradient;  // (dx, dy, ds)
  float dxx, dyy, dss, dxy, dxs, dys;

  /// The Hessian in (x, y, s) order.
  cv::Matx33f hessian() const {
    return cv::Matx33f(dxx, dxy, dxs, dxy, dyy, dys, dxs, dys, dss);
  }
};

/// The derivatives of dog(o, layer) of `space` at row r, column c (which must have a
/// neighbour on every side, in layers layer - 1 and layer + 1 too).
DogDerivatives dogDerivatives(const ScaleSpace& space, int o, int layer, int r, int c);

/// An extremum refined in octave-image coordinates.
struct Refined {
  int r, c, layer;   // integer sample after the Newton steps
  float xr, xc, xi;  // sub-sample offsets in [-0.5, 0.5] (up to 1 in x, y after a cycle)
  float contrast;    // interpolated DoG value
};

/// Fits a 3-D quadratic to the DoG around (r, c, layer) of one slice and moves to
/// the sample nearest its extremum, as SIFT (Lowe 2004, sec. 4):
///   x_hat = -H^-1 g,   D(x_hat) = D + g . x_hat / 2,
/// then rejects low contrast (|D(x_hat)| * layers < contrastThreshold) and edges
/// (det(H_xy) <= 0 or tr(H_xy)^2 / det(H_xy) >= (e + 1)^2 / e, e = edgeThreshold).
/// False if rejected, if the fit is singular, if it leaves the searched layers or
/// the border, or if it does not settle within the allowed steps.
bool refine(const ScaleSpace& space, int o, const DetectParams& params, int r, int c, int layer,
            Refined& out);

/// Sub-slope offset, in slope steps, of the feature's response peak across slices
/// k - 1, k, k + 1, from D-, D0, D+: each slice's DoG at the refined sub-pixel position
/// and scale (its quadratic model). When all three share a sign, the vertex of the
/// parabola through log |D| (a Gaussian fit: a blob's response falls off about as a
/// Gaussian in the slope error),
///   delta = (ln|D-| - ln|D+|) / (2 (ln|D-| - 2 ln|D0| + ln|D+|)),
/// else that of the parabola through D, (D- - D+) / (2 (D- - 2 D0 + D+)); clamped to
/// [-1/2, 1/2] so the keypoint stays nearest to its detection slice; 0 at the ends of
/// a hand-set slope range and where the profile is flat. docs/SLOPES.md.
float subSlopeOffset(const SliceNeighbourhood& slices, int o, const Refined& e);

/// Unpacks cv::SIFT's keypoint octave field into (octave index o >= 0 of our
/// pyramid, layer). Returns false if it names an octave or layer the pyramid lacks.
bool unpackOctave(const cv::KeyPoint& keypoint, int octaves, int layers, int firstOctave, int& o,
                  int& layer);

}  // namespace detail
}  // namespace liff
