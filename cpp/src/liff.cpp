// LiFF_Impl: the detector's parameters, persistence, and the orchestration of one
// call, step by step as cv::SIFT's SIFT_Impl::detectAndCompute:
//
//   check the input -> plan the focal stack's slopes -> fit the memory limit ->
//   convert the light field -> either
//     describe the given keypoints (compute), or
//     detect over a window sliding along the slopes, describing each batch while
//     its scale spaces are held -> sort and deduplicate -> retain the best.
#include <algorithm>
#include <climits>
#include <cmath>
#include <liff/liff.hpp>
#include <mutex>

#include "descriptor.hpp"
#include "detections.hpp"
#include "light_field.hpp"
#include "memory.hpp"
#include "pipeline.hpp"
#include "profile.hpp"
#include "require.hpp"
#include "scale_space.hpp"
#include "slope_plan.hpp"
#include "slope_range.hpp"
#include "view_borders.hpp"
#include "working_memory.hpp"

namespace liff {

double keypointSlope(const cv::KeyPoint& keypoint) { return keypoint.class_id / kSlopeScale; }

int slopeToClassId(double slope) {
  const double scaled = std::round(slope * kSlopeScale);
  if (!(std::abs(scaled) <= double(INT_MAX)))
    CV_Error(cv::Error::StsOutOfRange,
             cv::format("LiFF: slope %g cannot be stored in class_id; expected |slope| < %g", slope,
                        INT_MAX / kSlopeScale));
  return int(scaled);
}

cv::String LiFF::getDefaultName() const { return "Feature2D.LiFF"; }

void LiFF::read(const cv::String& fileName) { read(openParameterFile(fileName).root()); }

namespace {

using detail::Call;
using detail::Detections;
using detail::LightField;
using detail::SlopePlan;

using detail::require;

constexpr double kBytesPerMB = 1024.0 * 1024.0;

// Slices searched together: one per thread, so that building their scale spaces
// keeps every thread busy; memory stays at (batch + 2) scale spaces. Results do
// not depend on it, so when memory is short the batch shrinks; when even one slice
// at a time does not fit, fail now, before the large allocations.
// Share of the memory limit above which a call gives the survey's kept buffers back
// before detecting: they are kept for the next call's survey, and the detection cannot
// use them (other sizes).
constexpr double kTightMemoryShare = 0.8;

int sliceBatch(const LightField& lf, const detail::MemoryEstimate& need, double limitMB,
               bool& tight) {
  tight = false;
  int batch = std::max(1, detail::plannedThreads());
  const bool automatic = limitMB == 0;
  const double limit = automatic ? detail::availableMemoryBytes() : limitMB * kBytesPerMB;
  if (limit <= 0 || std::isinf(limit)) return batch;  // unknown or unlimited
  while (batch > 1 && need.total(batch) > limit) --batch;
  tight = need.total(batch) > kTightMemoryShare * limit;
  if (need.total(batch) > limit)
    CV_Error(cv::Error::StsNoMem,
             cv::format("LiFF: a light field of %d x %d views of %d x %d pixels needs about "
                        "%.0f MB (grey light field %.0f MB, %d scale space(s) of %.0f MB, %.0f MB "
                        "while building one, %d focal slice(s) of %.1f MB, slope survey %.0f MB, "
                        "%.0f MB for %s%.0f keypoints), "
                        "more than the memory "
                        "limit of %.4g MB (%s); "
                        "expected a light field that fits: crop or downsample the views, or "
                        "raise the limit with setMemoryLimitMB",
                        lf.T, lf.S, lf.V, lf.U, need.total(1) / kBytesPerMB,
                        need.lightFieldBytes / kBytesPerMB, need.heldSlices(1),
                        need.sliceBytes / kBytesPerMB, need.scratchBytes / kBytesPerMB,
                        need.focalSlices(1), need.focalSliceBytes / kBytesPerMB,
                        need.surveyBytes / kBytesPerMB, need.keypointTotal() / kBytesPerMB,
                        need.describing ? "" : "about ", need.keypoints, limit / kBytesPerMB,
                        automatic ? "automatic: the memory available now" : "setMemoryLimitMB"));
  return batch;
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
                               "infinity = no limit)",
                               v));
    memoryLimitMB_ = v;
  }
  double getMemoryLimitMB() const override { return memoryLimitMB_; }

  std::vector<double> slopesFor(int T, int S) const override {
    require(T >= 1 && S >= 1,
            cv::format("T = %d, S = %d views; expected at least 1 view in each direction", T, S));
    if (detail::automaticRange(parameters_) && (T > 1 || S > 1))
      CV_Error(cv::Error::StsBadArg,
               "LiFF: slopesFor(T, S) with an automatic slope range (firstSlope = -inf or "
               "lastSlope = +inf): the slopes depend on the light field; expected "
               "slopesFor(lightField), or getSlicesUsed() after a detection");
    if (T == 1 && S == 1 && detail::automaticRange(parameters_))
      return {detail::gridOrigin(parameters_)};
    return detail::uniformPlan(parameters_, T, S).slopes;
  }
  std::vector<double> slopesFor(cv::InputArray lightField) override;
  std::vector<double> getSlicesUsed() const override { return getSlopeRangeReport().slicesUsed; }
  std::vector<double> getSearchedSlopes() const override {
    return getSlopeRangeReport().searchedSlopes;
  }
  SlopeRangeReport getSlopeRangeReport() const override {
    std::lock_guard<std::mutex> lock(lastMutex_);
    return lastReport_;
  }
  detail::MemoryEstimate lastMemoryEstimate(int& batch) const {
    std::lock_guard<std::mutex> lock(lastMutex_);
    batch = lastBatch_;
    return lastEstimate_;
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
      CV_Error(cv::Error::StsBadArg, "LiFF: read() found parameters of '" + cv::String(fn["name"]) +
                                         "'; expected '" + getDefaultName() + "'");
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
  // The slices of one call (for compute(), `describing` holds the given keypoints),
  // for the converted light field `lf`.
  SlopePlan planSlices(const Parameters& parameters, const LightField& lf, int batch,
                       const std::vector<cv::KeyPoint>* describing) const;
  // The report of a call on `lf` with `parameters` that built `plan` (before its features).
  static SlopeRangeReport planReport(const Parameters& parameters, const LightField& lf,
                                     const SlopePlan& plan);
  // The report's end counts and, where many features sit at a hand-set end, the survey
  // of `lf` (parameters' own, with the automatic range) for structure beyond it.
  static void reportEnds(const Parameters& parameters, const LightField& lf, int batch,
                         const std::vector<cv::KeyPoint>& keypoints, SlopeRangeReport& report);
  void remember(SlopeRangeReport report);
  // Fits the memory limit (the slices built at once, `batch`) and converts `input`
  // into `lf`, whose sizes checkLightField set; returns the memory estimate.
  // `describing`: for compute(), the `described` keypoints given; `wantDescriptors`:
  // descriptors are returned.
  detail::MemoryEstimate convert(const Parameters& parameters, const cv::Mat& input, LightField& lf,
                                 int& batch, bool describing, size_t described,
                                 bool wantDescriptors) const;

  Parameters parameters_;
  double memoryLimitMB_ = 0;
  mutable std::mutex lastMutex_;  // guards the last call's report (calls may be concurrent)
  SlopeRangeReport lastReport_;
  detail::MemoryEstimate lastEstimate_;  // the last call's memory estimate, its batch
  int lastBatch_ = 0;
};

SlopePlan LiFF_Impl::planSlices(const Parameters& parameters, const LightField& lf, int batch,
                                const std::vector<cv::KeyPoint>* describing) const {
  if (!detail::automaticRange(parameters)) {
    SlopePlan plan = detail::uniformPlan(parameters, lf.T, lf.S);
    detail::setBlurTarget(plan, lf.T, lf.S, false);
    return plan;
  }
  // compute() describes on the grid detection uses, without a survey (the survey sets
  // only which grid slices are built), unless numSlopes spreads slices over its range
  // or two views make the plan a fixed one (no survey either).
  if (describing && detail::surveyed(lf.T, lf.S) && parameters.numSlopes == 0) {
    std::vector<double> slopes;
    for (const cv::KeyPoint& kp : *describing) slopes.push_back(keypointSlope(kp));
    return detail::describingPlan(lf.T, lf.S, slopes, detail::gridOrigin(parameters));
  }
  return detail::automaticPlan(lf, parameters, batch);
}

SlopeRangeReport LiFF_Impl::planReport(const Parameters& parameters, const LightField& lf,
                                       const SlopePlan& plan) {
  SlopeRangeReport report;
  report.slicesUsed = plan.slopes;
  for (int k = 0; k < plan.size(); ++k)
    if (plan.searched[k]) report.searchedSlopes.push_back(plan.slopes[k]);
  report.T = lf.T;
  report.S = lf.S;
  report.V = lf.V;
  report.U = lf.U;
  report.automaticRange = std::isinf(parameters.firstSlope) && std::isinf(parameters.lastSlope);
  // The reach bounds an automatic end, of a half-automatic range too.
  if (detail::automaticRange(parameters) && detail::surveyed(lf.T, lf.S))
    report.automaticReach = detail::largestSlope(lf.T, lf.S, lf.V, lf.U);
  report.surveyFoundNothing = plan.surveyFoundNothing;
  report.structureBeyondReach = plan.structureBeyondReach;
  return report;
}

void LiFF_Impl::reportEnds(const Parameters& parameters, const LightField& lf, int batch,
                           const std::vector<cv::KeyPoint>& keypoints, SlopeRangeReport& report) {
  const std::vector<double>& searched = report.searchedSlopes;
  const bool firstSet = std::isfinite(parameters.firstSlope);
  const bool lastSet = std::isfinite(parameters.lastSlope);
  if (!(firstSet || lastSet) || searched.size() < 2 || keypoints.empty()) return;
  const double tolerance = 1.0 / kSlopeScale;  // one class_id step
  for (const cv::KeyPoint& kp : keypoints) {
    const double slope = keypointSlope(kp);
    report.featuresAtFirstSlope += firstSet && std::abs(slope - searched.front()) <= tolerance;
    report.featuresAtLastSlope += lastSet && std::abs(slope - searched.back()) <= tolerance;
  }
  if (report.featuresAtFirstSlope + report.featuresAtLastSlope <=
      kRangeEndShare * double(keypoints.size()))
    return;
  // Many features at a hand-set end: their slopes may be pinned there. The survey of the
  // light field already converted finds what lies beyond (docs/SLOPES.md).
  report.endsSurveyed = true;
  report.surveyedSlopes = detail::surveySlopes(lf, parameters, -HUGE_VAL, HUGE_VAL, batch).slopes;
}

void LiFF_Impl::remember(SlopeRangeReport report) {
  std::lock_guard<std::mutex> lock(lastMutex_);
  lastReport_ = std::move(report);
}

detail::MemoryEstimate LiFF_Impl::convert(const Parameters& parameters, const cv::Mat& input,
                                          LightField& lf, int& batch, bool describing,
                                          size_t described, bool wantDescriptors) const {
  // Memory check before the grey conversion, the largest single allocation.
  const int octaves = detail::numOctaves(lf.viewSize(), parameters.firstOctave);
  detail::MemoryEstimate need = detail::sliceMemory(
      lf.viewSize(), parameters.nOctaveLayers, octaves, parameters.firstOctave, describing,
      described,
      wantDescriptors ? detail::kDescriptorSize * int(CV_ELEM_SIZE(parameters.descriptorType)) : 0);
  need.lightFieldBytes = detail::conversionBytes(input, lf);
  if (!detail::automaticRange(parameters))
    need.planSlices = detail::uniformPlan(parameters, lf.T, lf.S).size();
  else if (!detail::surveyed(lf.T, lf.S))  // one or two views: a plan of their counts alone
    // (automaticPlan reads no pixel there: lf is not converted yet)
    need.planSlices = detail::automaticPlan(lf, parameters, 1).size();
  else if (!(describing && parameters.numSlopes == 0))  // compute() skips it (planSlices)
    // alpha (2 or 4 channels) may become weights
    need.surveyBytes = detail::surveyMemoryBytes(lf, input.channels() % 2 == 0);
  batch = sliceBatch(lf, need, memoryLimitMB_, need.nearLimit);
  detail::convertLightField(input, lf);
  return need;
}

std::vector<double> LiFF_Impl::slopesFor(cv::InputArray image) {
  const Parameters parameters = parameters_;
  const cv::Mat input = image.getMat();
  LightField lf = detail::checkLightField(input);
  detail::installWorkingMemory();
  if (!detail::automaticRange(parameters) || (lf.T == 1 && lf.S == 1)) return slopesFor(lf.T, lf.S);
  int batch = 1;
  convert(parameters, input, lf, batch, false, 0, false);
  return planSlices(parameters, lf, batch, nullptr).slopes;
}

void LiFF_Impl::detectAndCompute(cv::InputArray image, cv::InputArray maskArray,
                                 std::vector<cv::KeyPoint>& keypoints,
                                 cv::OutputArray descriptorsOut, bool useProvidedKeypoints) {
  const Parameters parameters = parameters_;  // this call's, whatever setters do meanwhile
  detail::installWorkingMemory();
  const cv::Mat input = image.getMat();
  LightField lf = detail::checkLightField(input);
  const cv::Mat mask = maskArray.getMat();
  detail::checkMask(mask, lf.viewSize());
  if (!detail::automaticRange(parameters)) detail::uniformPlan(parameters, lf.T, lf.S);  // checks
  int batch = 1;
  const bool wantDescriptors = descriptorsOut.needed();
  const detail::MemoryEstimate need =
      convert(parameters, input, lf, batch, useProvidedKeypoints,
              useProvidedKeypoints ? keypoints.size() : 0, wantDescriptors);
  {
    std::lock_guard<std::mutex> lock(lastMutex_);
    lastEstimate_ = need;
    lastBatch_ = batch;
  }
  const SlopePlan slices =
      planSlices(parameters, lf, batch, useProvidedKeypoints ? &keypoints : nullptr);
  SlopeRangeReport report = planReport(parameters, lf, slices);
  // Near the memory limit, the buffers the survey freed (kept for the next call's survey,
  // of sizes the detection does not use) go back now rather than sit beside its own.
  if (need.nearLimit) releaseWorkingMemory();

  Call call{parameters,
            lf,
            slices,
            detail::ScaleSpaceSettings{parameters.nOctaveLayers, parameters.sigma,
                                       detail::numOctaves(lf.viewSize(), parameters.firstOctave),
                                       parameters.firstOctave, !useProvidedKeypoints},
            batch,
            need.slicesAhead(batch)};
  if (useProvidedKeypoints) {
    cv::Mat descriptors;
    detail::describeProvidedKeypoints(call, keypoints, wantDescriptors, descriptors);
    if (wantDescriptors) descriptors.copyTo(descriptorsOut);
    report.featuresFound = report.featuresReturned = int(keypoints.size());
    remember(std::move(report));
    return;
  }
  Detections detections = detail::detectInSlices(call, mask, wantDescriptors);
  // Near the views' borders, features only where the views that see them agree.
  detail::dropBorderGhosts(lf, parameters.nOctaveLayers, detections);
  detail::sortAndDeduplicate(detections);
  report.featuresFound = int(detections.keypoints.size());
  detail::retainBest(detections, parameters.nfeatures);
  report.featuresReturned = int(detections.keypoints.size());
  reportEnds(parameters, lf, batch, detections.keypoints, report);
  if (wantDescriptors)
    detections.copyDescriptorsTo(descriptorsOut, detail::kDescriptorSize,
                                 parameters.descriptorType);
  keypoints.swap(detections.keypoints);
  remember(std::move(report));
}

}  // namespace

cv::Ptr<LiFF> LiFF::create(const Parameters& parameters) {
  parameters.check();  // each value first, so that its error names it
  checkSlopeOrder(parameters);
  return cv::makePtr<LiFF_Impl>(parameters);
}

cv::Ptr<LiFF> LiFF::create(int nfeatures, int nOctaveLayers, double contrastThreshold,
                           double edgeThreshold, double sigma, double firstSlope, double lastSlope,
                           int numSlopes, int descriptorType, bool rootSift, int firstOctave) {
  // Every parameter of the table from the argument of its name: one the signature
  // lacks does not compile (and test_api.cpp calls this with the table, in order).
  Parameters parameters;
#define LIFF_SET_PARAMETER(Type, name, Name, value, help) parameters.name = name;
  LIFF_PARAMETERS(LIFF_SET_PARAMETER)
#undef LIFF_SET_PARAMETER
  return create(parameters);
}

detail::MemoryEstimate detail::lastMemoryEstimate(const LiFF& detector, int& batch) {
  batch = 0;
  const auto* impl = dynamic_cast<const LiFF_Impl*>(&detector);
  return impl != nullptr ? impl->lastMemoryEstimate(batch) : detail::MemoryEstimate();
}

}  // namespace liff
