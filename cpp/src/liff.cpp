// LiFF_Impl: the detector's parameters, persistence, and the orchestration of one
// call, step by step as cv::SIFT's SIFT_Impl::detectAndCompute:
//
//   check the input -> plan the focal stack's slopes -> fit the memory limit ->
//   convert the light field -> either
//     describe the given keypoints (compute), or
//     detect over a window sliding along the slopes, describing each batch while
//     its scale spaces are held -> sort and deduplicate -> retain the best.
#include <liff/liff.hpp>

#include "descriptor.hpp"
#include "detections.hpp"
#include "extrema.hpp"
#include "light_field.hpp"
#include "memory.hpp"
#include "profile.hpp"
#include "scale_space.hpp"
#include "slice_window.hpp"
#include "slope_plan.hpp"

#include <algorithm>
#include <climits>
#include <cmath>

namespace liff {

double keypointSlope(const cv::KeyPoint& keypoint) { return keypoint.class_id / kSlopeScale; }

int slopeToClassId(double slope) {
  const double scaled = std::round(slope * kSlopeScale);
  if (!(std::abs(scaled) <= double(INT_MAX)))
    CV_Error(cv::Error::StsOutOfRange,
             cv::format("LiFF: slope %g cannot be stored in class_id; expected |slope| < %g",
                        slope, INT_MAX / kSlopeScale));
  return int(scaled);
}

cv::String LiFF::getDefaultName() const { return "Feature2D.LiFF"; }

namespace {

using detail::Detections;
using detail::LightField;
using detail::SliceWindow;
using detail::SlopePlan;

void require(bool ok, const cv::String& message) {
  if (!ok) CV_Error(cv::Error::StsOutOfRange, "LiFF: " + message);
}

// compute() drops keypoints with |x|, |y| or size at least this (pixels): they cannot
// be described, and would overflow the sampling window's integer arithmetic.
constexpr float kMaxCoordinate = 1e6f;
// Rows of one octave image that one extrema-search task covers.
constexpr int kRowsPerSearchTask = 32;
constexpr double kBytesPerMB = 1024.0 * 1024.0;

// Slices searched together: one per thread, so that building their scale spaces
// keeps every thread busy; memory stays at (batch + 2) scale spaces. Results do
// not depend on it, so when memory is short the batch shrinks; when even one slice
// at a time does not fit, fail now, before the large allocations.
int sliceBatch(const LightField& lf, const detail::MemoryEstimate& need, double limitMB) {
  int batch = std::max(1, cv::getNumThreads());
  const bool automatic = limitMB == 0;
  const double limit = automatic ? detail::availableMemoryBytes() : limitMB * kBytesPerMB;
  if (limit <= 0 || std::isinf(limit)) return batch;  // unknown or unlimited
  while (batch > 1 && need.total(batch) > limit) --batch;
  if (need.total(batch) > limit)
    CV_Error(cv::Error::StsNoMem,
             cv::format("LiFF: a light field of %d x %d views of %d x %d pixels needs about "
                        "%.0f MB (grey light field %.0f MB, 3 scale spaces of %.0f MB, %.0f MB "
                        "while building one, %d focal slices of %.1f MB), more than the memory "
                        "limit of %.4g MB (%s); "
                        "expected a light field that fits: crop or downsample the views, or "
                        "raise the limit with setMemoryLimitMB",
                        lf.T, lf.S, lf.V, lf.U, need.total(1) / kBytesPerMB,
                        need.lightFieldBytes / kBytesPerMB, need.windowSliceBytes / kBytesPerMB,
                        need.buildBytes / kBytesPerMB, need.slicesAhead(1),
                        need.focalSliceBytes / kBytesPerMB, limit / kBytesPerMB,
                        automatic ? "automatic: the memory available now" : "setMemoryLimitMB"));
  return batch;
}

// Descriptors of keypoints[j] on the scale space of slice sliceOf[j] (held by
// `window`), into rows of `descriptors`, in parallel.
void describe(const std::vector<cv::KeyPoint>& keypoints, const std::vector<int>& sliceOf,
              const SliceWindow& window, bool rootSift, cv::Mat& descriptors) {
  cv::parallel_for_(cv::Range(0, int(keypoints.size())), [&](const cv::Range& range) {
    detail::StageTimer timer(detail::kDescriptors);
    for (int j = range.start; j < range.end; ++j)
      detail::describeKeypoint(window.at(sliceOf[j]), keypoints[j], rootSift,
                               descriptors.row(j));
  });
}

// The plan's slices each keypoint is described on: the grid slope nearest its own.
std::vector<int> nearestSlices(const SlopePlan& plan, const std::vector<cv::KeyPoint>& keypoints) {
  std::vector<int> slices;
  slices.reserve(keypoints.size());
  for (const cv::KeyPoint& kp : keypoints) slices.push_back(plan.nearest(keypointSlope(kp)));
  return slices;
}

// Everything one call needs, fixed at its start.
struct Call {
  const Parameters& parameters;
  const LightField& lf;
  const SlopePlan& plan;
  detail::ScaleSpaceSettings settings;
  int batch;        // slices built at once
  int renderAhead;  // focal slices rendered ahead in slope order (detection)
};

// compute(): describes the given keypoints, each on the slice nearest its slope, and
// drops those whose packed octave/layer this light field's pyramid lacks (as
// cv::Feature2D does). Each needed scale space is built once, `batch` at a time.
void describeProvidedKeypoints(const Call& call, std::vector<cv::KeyPoint>& keypoints,
                               bool wantDescriptors, cv::Mat& descriptors) {
  std::vector<cv::KeyPoint> kept;
  for (const cv::KeyPoint& kp : keypoints) {
    int o, layer;
    const bool usable = std::abs(kp.pt.x) < kMaxCoordinate &&
                        std::abs(kp.pt.y) < kMaxCoordinate && kp.size > 0 &&
                        kp.size < kMaxCoordinate && std::isfinite(kp.angle);
    if (call.settings.octaves >= 1 && usable &&
        detail::unpackOctave(kp, call.settings.octaves, call.settings.layers, o, layer))
      kept.push_back(kp);
  }
  keypoints = kept;
  if (!wantDescriptors) return;
  descriptors.create(int(kept.size()), detail::kDescriptorSize, call.parameters.descriptorType);
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
        rows.push_back(int(j));
      }
    cv::Mat groupDescriptors(int(group.size()), detail::kDescriptorSize,
                             call.parameters.descriptorType);
    describe(group, groupSlice, window, call.parameters.rootSift, groupDescriptors);
    for (size_t j = 0; j < rows.size(); ++j)
      groupDescriptors.row(int(j)).copyTo(descriptors.row(rows[j]));
  }
}

// Searches the searched slices `batch` (plan indices, whose scale spaces and grid
// neighbours `window` holds) as fixed row-stripe tasks over all their octaves and
// layers, so every thread stays busy; keypoints come out in task order.
std::vector<cv::KeyPoint> searchSlices(const Call& call, const SliceWindow& window,
                                       const std::vector<int>& batch, const cv::Mat& mask) {
  const Parameters& p = call.parameters;
  const detail::DetectParams params{p.nOctaveLayers, p.contrastThreshold, p.edgeThreshold,
                                    p.sigma};
  struct Job {
    int slice;
    detail::SearchTask task;
  };
  std::vector<Job> jobs;
  for (int k : batch)
    for (const detail::SearchTask& task : detail::searchTasks(window.at(k), kRowsPerSearchTask))
      jobs.push_back({k, task});
  std::vector<std::vector<cv::KeyPoint>> found(jobs.size());
  cv::parallel_for_(cv::Range(0, int(jobs.size())), [&](const cv::Range& range) {
    for (int j = range.start; j < range.end; ++j) {
      const int k = jobs[j].slice;
      detail::SliceNeighbourhood slices;
      slices.here = &window.at(k);
      slices.below = window.below(k);
      slices.above = window.above(k);
      slices.slope = call.plan.slopes[k];
      slices.slopeStep = call.plan.step;
      detail::StageTimer timer(detail::kExtrema);
      found[j] = detail::findKeypoints(slices, params, mask, jobs[j].task);
    }
  });
  std::vector<cv::KeyPoint> keypoints;
  for (const std::vector<cv::KeyPoint>& part : found)
    keypoints.insert(keypoints.end(), part.begin(), part.end());
  return keypoints;
}

// Detection: a window sliding along the slopes holds the scale spaces of the slices
// being searched and their grid neighbours; each batch of searched slices is built,
// searched and described in parallel, and results are concatenated in slice order.
Detections detectInSlices(const Call& call, const cv::Mat& mask, bool wantDescriptors) {
  std::vector<int> searched;
  for (int k = 0; k < call.plan.size(); ++k)
    if (call.plan.searched[k]) searched.push_back(k);
  Detections all;
  if (wantDescriptors)
    all.descriptors.create(0, detail::kDescriptorSize, call.parameters.descriptorType);
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

    const std::vector<cv::KeyPoint> keypoints = searchSlices(call, window, batch, mask);
    all.keypoints.insert(all.keypoints.end(), keypoints.begin(), keypoints.end());
    if (wantDescriptors && !keypoints.empty()) {
      // Each keypoint's nearest slice is within one of its detection slice: held.
      cv::Mat block(int(keypoints.size()), detail::kDescriptorSize,
                    call.parameters.descriptorType);
      describe(keypoints, nearestSlices(call.plan, keypoints), window, call.parameters.rootSift,
               block);
      all.descriptors.push_back(block);
    }
    // Keep only what the next batch needs from here on (its lower neighbour); the
    // others' memory goes to the next slices.
    if (first + call.batch < searched.size()) window.releaseBelow(searched[first + call.batch] - 1);
  }
  return all;
}

class LiFF_Impl : public LiFF {
 public:
  explicit LiFF_Impl(const Parameters& parameters) { setParameters(parameters); }

  // --- parameters: each setter checks its value before taking it ----------------------
#define LIFF_DEFINE_ACCESSORS(Type, name, Name, value, help) \
  void set##Name(Type v) override {                          \
    Parameters next = parameters_;                           \
    next.name = v;                                           \
    setParameters(next);                                     \
  }                                                          \
  Type get##Name() const override { return parameters_.name; }
  LIFF_PARAMETERS(LIFF_DEFINE_ACCESSORS)
#undef LIFF_DEFINE_ACCESSORS

  Parameters getParameters() const override { return parameters_; }
  void setParameters(const Parameters& parameters) override {
    parameters.check();
    parameters_ = parameters;
  }
  void setMemoryLimitMB(double v) override {
    require(v >= 0, cv::format("memoryLimitMB = %g; expected >= 0 (0 = automatic, "
                               "infinity = no limit)", v));
    memoryLimitMB_ = v;
  }
  double getMemoryLimitMB() const override { return memoryLimitMB_; }

  std::vector<double> slopesFor(int T, int S) const override {
    return detail::uniformPlan(parameters_, T, S).slopes;
  }

  // --- Feature2D ----------------------------------------------------------------------
  int descriptorSize() const override { return detail::kDescriptorSize; }
  int descriptorType() const override { return parameters_.descriptorType; }
  int defaultNorm() const override { return cv::NORM_L2; }
  bool empty() const override { return false; }
  cv::String getDefaultName() const override { return LiFF::getDefaultName(); }

  void write(cv::FileStorage& fs) const override {
    writeFormat(fs);
    fs << "name" << getDefaultName();
    writeParameters(fs, parameters_);
  }

  void read(const cv::FileNode& node) override {
    // Algorithm::save() nests the parameters under the default name; accept both.
    cv::FileNode fn = node;
    if (fn.isMap() && !fn[getDefaultName()].empty()) fn = fn[getDefaultName()];
    if (fn.isMap() && !fn["name"].empty() && cv::String(fn["name"]) != getDefaultName())
      CV_Error(cv::Error::StsBadArg, "LiFF: read() found parameters of '" +
                                         cv::String(fn["name"]) + "'; expected '" +
                                         getDefaultName() + "'");
    readParameters(fn, parameters_);
  }

  void detectAndCompute(cv::InputArray image, cv::InputArray mask,
                        std::vector<cv::KeyPoint>& keypoints, cv::OutputArray descriptors,
                        bool useProvidedKeypoints) override;

  // Route straight through detectAndCompute, which validates the input: Feature2D's
  // versions return nothing for an empty image instead of saying it is empty.
  void detect(cv::InputArray image, std::vector<cv::KeyPoint>& keypoints,
              cv::InputArray mask) override {
    detectAndCompute(image, mask, keypoints, cv::noArray(), false);
  }
  void compute(cv::InputArray image, std::vector<cv::KeyPoint>& keypoints,
               cv::OutputArray descriptors) override {
    detectAndCompute(image, cv::noArray(), keypoints, descriptors, true);
  }
  using cv::Feature2D::compute;
  using cv::Feature2D::detect;

 private:
  Parameters parameters_;
  double memoryLimitMB_ = 0;
};

void LiFF_Impl::detectAndCompute(cv::InputArray image, cv::InputArray maskArray,
                                 std::vector<cv::KeyPoint>& keypoints,
                                 cv::OutputArray descriptorsOut, bool useProvidedKeypoints) {
  const Parameters parameters = parameters_;  // this call's, whatever setters do meanwhile
  const cv::Mat input = image.getMat();
  LightField lf = detail::checkLightField(input);
  const cv::Mat mask = maskArray.getMat();
  detail::checkMask(mask, lf.viewSize());
  const SlopePlan plan = detail::uniformPlan(parameters, lf.T, lf.S);
  const int octaves = detail::numOctaves(lf.viewSize());

  // Memory check before the grey conversion, the largest single allocation.
  detail::MemoryEstimate need =
      detail::sliceMemory(lf.viewSize(), parameters.nOctaveLayers, octaves);
  need.lightFieldBytes = detail::conversionBytes(input, lf);
  const int batch = sliceBatch(lf, need, memoryLimitMB_);
  detail::convertLightField(input, lf);

  const bool wantDescriptors = descriptorsOut.needed();
  Call call{parameters, lf, plan,
            detail::ScaleSpaceSettings{parameters.nOctaveLayers, parameters.sigma, octaves,
                                       !useProvidedKeypoints},
            batch, need.slicesAhead(batch)};
  if (useProvidedKeypoints) {
    cv::Mat descriptors;
    describeProvidedKeypoints(call, keypoints, wantDescriptors, descriptors);
    if (wantDescriptors) descriptors.copyTo(descriptorsOut);
    return;
  }
  Detections detections = detectInSlices(call, mask, wantDescriptors);
  detail::sortAndDeduplicate(detections);
  detail::retainBest(detections, parameters.nfeatures);
  keypoints.swap(detections.keypoints);
  if (wantDescriptors) detections.descriptors.copyTo(descriptorsOut);
}

}  // namespace

cv::Ptr<LiFF> LiFF::create(const Parameters& parameters) {
  return cv::makePtr<LiFF_Impl>(parameters);
}

cv::Ptr<LiFF> LiFF::create(int nfeatures, int nOctaveLayers, double contrastThreshold,
                           double edgeThreshold, double sigma, double firstSlope, double lastSlope,
                           int numSlopes, int descriptorType, bool rootSift) {
  Parameters parameters;
  parameters.nfeatures = nfeatures;
  parameters.nOctaveLayers = nOctaveLayers;
  parameters.contrastThreshold = contrastThreshold;
  parameters.edgeThreshold = edgeThreshold;
  parameters.sigma = sigma;
  parameters.firstSlope = firstSlope;
  parameters.lastSlope = lastSlope;
  parameters.numSlopes = numSlopes;
  parameters.descriptorType = descriptorType;
  parameters.rootSift = rootSift;
  return create(parameters);
}

}  // namespace liff
