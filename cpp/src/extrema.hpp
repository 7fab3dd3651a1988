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

/// Unpacks cv::SIFT's keypoint octave field into (octave index o >= 0 of our
/// pyramid, layer). Returns false if it names an octave or layer the pyramid lacks.
bool unpackOctave(const cv::KeyPoint& keypoint, int octaves, int layers, int& o, int& layer);

}  // namespace detail
}  // namespace liff
