// The detection and description passes over a light field's focal slices, given the
// slices to use (a SlopePlan): what one call of the detector runs, and what the
// automatic slope range runs on a decimated light field.
#pragma once

#include <liff/parameters.hpp>
#include <opencv2/core.hpp>
#include <vector>

#include "detections.hpp"
#include "light_field.hpp"
#include "slice_window.hpp"
#include "slope_plan.hpp"

namespace liff {
namespace detail {

/// Everything one pass needs, fixed at its start.
struct Call {
  const Parameters& parameters;
  const LightField& lf;
  const SlopePlan& plan;
  ScaleSpaceSettings settings;
  int batch;        // slices built at once
  int renderAhead;  // focal slices rendered ahead in slope order (detection)
};

/// compute(): describes `keypoints`, each on the plan's slice nearest its slope, and
/// keeps every keypoint in its place, as cv::SIFT does: one that cannot be described
/// (a packed octave/layer this light field's pyramid lacks, a non-finite or huge
/// position, a size <= 0, a non-finite angle) gets an all-zero descriptor, so the
/// caller's arrays stay aligned with the keypoints. Each needed scale space is built
/// once, `batch` at a time.
void describeProvidedKeypoints(const Call& call, const std::vector<cv::KeyPoint>& keypoints,
                               bool wantDescriptors, cv::Mat& descriptors);

/// Detection over the plan's searched slices: a window sliding along the slopes holds
/// the scale spaces of the slices being searched and their grid neighbours; each batch
/// of searched slices is built, searched (and described) in parallel, and results are
/// concatenated in slice order. Keypoints only inside `mask` (if not empty).
Detections detectInSlices(const Call& call, const cv::Mat& mask, bool wantDescriptors);

}  // namespace detail
}  // namespace liff
