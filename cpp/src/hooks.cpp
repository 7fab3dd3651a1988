// liff/hooks.hpp: the core's test and benchmark hooks, over its internals.
#include <liff/hooks.hpp>

#include <opencv2/core.hpp>

#include <cmath>

#include "light_field.hpp"
#include "memory.hpp"
#include "profile.hpp"
#include "slope_range.hpp"
#include "working_memory.hpp"

namespace liff {
namespace hooks {

void setProfiling(bool enabled) { detail::setProfiling(enabled); }

void resetProfile() { detail::resetProfile(); }

std::vector<std::string> stageNames() {
  // In the order of detail::Stage.
  return {"focal_stack", "scale_space", "extrema", "refinement", "descriptors"};
}

std::vector<double> stageSeconds(bool inLoops) {
  const auto seconds = detail::stageSeconds(inLoops);
  return std::vector<double>(seconds.begin(), seconds.end());
}

void setSliceBatch(int batch) { detail::setSliceBatchOverride(batch); }

std::vector<ParallelLoop> parallelLoops() {
  std::vector<ParallelLoop> loops;
  for (const detail::LoopRecord& record : detail::loopRecords())
    loops.push_back({record.name, record.wall, record.tasks});
  return loops;
}

MemoryEstimateParts lastMemoryEstimate(const LiFF& detector) {
  MemoryEstimateParts parts;
  const detail::MemoryEstimate need = detail::lastMemoryEstimate(detector, parts.batch);
  if (parts.batch > 0) parts.total = need.total(parts.batch);
  parts.lightField = need.lightFieldBytes;
  parts.survey = need.surveyBytes;
  return parts;
}

size_t workingMemoryPeakBytes(bool reset) { return detail::workingMemoryPeakBytes(reset); }

std::vector<double> surveySlopes(const LiFF& detector, cv::InputArray lightField) {
  const cv::Mat input = lightField.getMat();
  detail::LightField lf = detail::checkLightField(input);
  detail::convertLightField(input, lf);
  return detail::surveySlopes(lf, detector.getParameters(), -HUGE_VAL, HUGE_VAL,
                              std::max(1, cv::getNumThreads()))
      .slopes;
}

}  // namespace hooks
}  // namespace liff
