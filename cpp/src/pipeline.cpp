#include "pipeline.hpp"

#include <algorithm>
#include <cmath>
#include <liff/liff.hpp>

#include "descriptor.hpp"
#include "extrema.hpp"
#include "profile.hpp"

namespace liff {
namespace detail {
namespace {

// compute() drops keypoints with |x|, |y| or size at least this (pixels): they cannot
// be described, and would overflow the sampling window's integer arithmetic.
constexpr float kMaxCoordinate = 1e6f;
// Rows of one octave image that one extrema-search task covers.
constexpr int kRowsPerSearchTask = 32;

// Descriptors of keypoints[j] on the scale space of slice sliceOf[j] (held by
// `window`), into rows of `descriptors`, in parallel.
void describe(const std::vector<cv::KeyPoint>& keypoints, const std::vector<int>& sliceOf,
              const SliceWindow& window, bool rootSift, cv::Mat& descriptors) {
  parallelFor("descriptors", cv::Range(0, int(keypoints.size())), [&](const cv::Range& range) {
    StageTimer timer(kDescriptors);
    for (int j = range.start; j < range.end; ++j)
      describeKeypoint(window.at(sliceOf[j]), keypoints[j], rootSift, descriptors.row(j));
  });
}

// The plan's slices each keypoint is described on: the grid slope nearest its own.
std::vector<int> nearestSlices(const SlopePlan& plan, const std::vector<cv::KeyPoint>& keypoints) {
  std::vector<int> slices;
  slices.reserve(keypoints.size());
  for (const cv::KeyPoint& kp : keypoints) slices.push_back(plan.nearest(keypointSlope(kp)));
  return slices;
}

// One slice to search and the neighbours it is compared with (null: a side skipped).
struct Target {
  int slice;
  const ScaleSpace* below;
  const ScaleSpace* above;
};

// Searches `targets` (whose scale spaces `window` holds) as fixed row-stripe tasks
// over all their octaves and layers, so every thread stays busy; keypoints come out
// per target, in task order.
std::vector<std::vector<cv::KeyPoint>> searchSlices(const Call& call, const SliceWindow& window,
                                                    const std::vector<Target>& targets,
                                                    const cv::Mat& mask) {
  const Parameters& p = call.parameters;
  const DetectParams params{p.nOctaveLayers, p.contrastThreshold, p.edgeThreshold, p.sigma};
  struct Job {
    int target;
    SearchTask task;
  };
  std::vector<Job> jobs;
  for (int i = 0; i < int(targets.size()); ++i)
    for (const SearchTask& task : searchTasks(window.at(targets[i].slice), kRowsPerSearchTask))
      jobs.push_back({i, task});
  std::vector<std::vector<cv::KeyPoint>> found(jobs.size());
  parallelFor("extrema search", cv::Range(0, int(jobs.size())), [&](const cv::Range& range) {
    for (int j = range.start; j < range.end; ++j) {
      const Target& target = targets[jobs[j].target];
      SliceNeighbourhood slices;
      slices.here = &window.at(target.slice);
      slices.below = target.below;
      slices.above = target.above;
      slices.slope = call.plan.slopes[target.slice];
      slices.slopeStep = call.plan.step;
      StageTimer timer(kExtrema);
      found[j] = findKeypoints(slices, params, mask, jobs[j].task);
    }
  });
  std::vector<std::vector<cv::KeyPoint>> keypoints(targets.size());
  for (size_t j = 0; j < jobs.size(); ++j)
    keypoints[jobs[j].target].insert(keypoints[jobs[j].target].end(), found[j].begin(),
                                     found[j].end());
  return keypoints;
}

}  // namespace

// compute(): describes the given keypoints, each on the slice nearest its slope; those
// that cannot be described keep their place with an all-zero descriptor (as cv::SIFT).
// Each needed scale space is built once, `batch` at a time.
void describeProvidedKeypoints(const Call& call, const std::vector<cv::KeyPoint>& keypoints,
                               bool wantDescriptors, cv::Mat& descriptors) {
  if (!wantDescriptors) return;
  descriptors.create(int(keypoints.size()), kDescriptorSize, call.parameters.descriptorType);
  descriptors.setTo(0);
  std::vector<cv::KeyPoint> kept;  // the describable keypoints, and their rows
  std::vector<int> keptRows;
  for (size_t j = 0; j < keypoints.size(); ++j) {
    const cv::KeyPoint& kp = keypoints[j];
    int o, layer;
    const bool usable = std::abs(kp.pt.x) < kMaxCoordinate && std::abs(kp.pt.y) < kMaxCoordinate &&
                        kp.size > 0 && kp.size < kMaxCoordinate && std::isfinite(kp.angle);
    if (call.settings.octaves >= 1 && usable &&
        unpackOctave(kp, call.settings.octaves, call.settings.layers, call.settings.firstOctave, o,
                     layer)) {
      kept.push_back(kp);
      keptRows.push_back(int(j));
    }
  }
  const std::vector<int> sliceOf = nearestSlices(call.plan, kept);
  std::vector<int> needed(sliceOf);
  std::sort(needed.begin(), needed.end());
  needed.erase(std::unique(needed.begin(), needed.end()), needed.end());
  SliceWindow window(call.lf, call.plan, call.settings, call.batch, 0);
  for (size_t first = 0; first < needed.size(); first += call.batch) {
    window.releaseAll();
    window.require(std::vector<int>(needed.begin() + first,
                                    needed.begin() + std::min(needed.size(), first + call.batch)));
    std::vector<cv::KeyPoint> group;
    std::vector<int> groupSlice, rows;
    for (size_t j = 0; j < kept.size(); ++j)
      if (window.holds(sliceOf[j])) {
        group.push_back(kept[j]);
        groupSlice.push_back(sliceOf[j]);
        rows.push_back(keptRows[j]);
      }
    cv::Mat groupDescriptors(int(group.size()), kDescriptorSize, call.parameters.descriptorType);
    describe(group, groupSlice, window, call.parameters.rootSift, groupDescriptors);
    for (size_t j = 0; j < rows.size(); ++j)
      groupDescriptors.row(int(j)).copyTo(descriptors.row(rows[j]));
  }
}

// Detection: a window sliding along the slopes holds the scale spaces of the slices
// being searched and their grid neighbours; each batch of searched slices is built,
// searched and described in parallel, and results are concatenated in slice order.
Detections detectInSlices(const Call& call, const cv::Mat& mask, bool wantDescriptors) {
  std::vector<int> searched;
  for (int k = 0; k < call.plan.size(); ++k)
    if (call.plan.searched[k]) searched.push_back(k);
  Detections all;
  if (call.settings.octaves < 1) return all;
  SliceWindow window(call.lf, call.plan, call.settings, call.batch, call.renderAhead);
  for (size_t first = 0; first < searched.size(); first += call.batch) {
    const std::vector<int> batch(searched.begin() + first,
                                 searched.begin() + std::min(searched.size(), first + call.batch));
    std::vector<int> needed;
    for (int k : batch)
      for (int n = std::max(0, k - 1); n <= std::min(call.plan.size() - 1, k + 1); ++n)
        needed.push_back(n);
    std::sort(needed.begin(), needed.end());
    window.require(needed);

    std::vector<Target> targets;
    for (int k : batch) targets.push_back({k, window.below(k), window.above(k)});
    std::vector<cv::KeyPoint> keypoints;
    for (const std::vector<cv::KeyPoint>& found : searchSlices(call, window, targets, mask))
      keypoints.insert(keypoints.end(), found.begin(), found.end());
    cv::Mat block;  // each batch's descriptors, copied once into the output at the end
    if (wantDescriptors && !keypoints.empty()) {
      // Each keypoint's nearest slice is within one of its detection slice: held.
      block.create(int(keypoints.size()), kDescriptorSize, call.parameters.descriptorType);
      describe(keypoints, nearestSlices(call.plan, keypoints), window, call.parameters.rootSift,
               block);
    }
    all.append(keypoints, block);
    // Keep only what the next batch needs from here on (its lower neighbour); the
    // others' memory goes to the next slices.
    if (first + call.batch < searched.size()) window.releaseBelow(searched[first + call.batch] - 1);
  }
  return all;
}

}  // namespace detail
}  // namespace liff
