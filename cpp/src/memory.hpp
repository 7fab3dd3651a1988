// Memory the detector will need, and memory the machine has, so that a light field
// too large fails early with a clear error instead of an out-of-memory kill.
#pragma once

#include <opencv2/core.hpp>

#include <algorithm>

namespace liff {
namespace detail {

/// Bytes of one slice's Gaussian and DoG pyramids (CV_32F, the first octave
/// upsampled 2^-firstOctave times): per octave the images halve; a full pyramid
/// holds layers + 3 Gaussians and layers + 2 DoGs per octave, a detection-only one
/// keeps `layers` Gaussians.
double scaleSpaceBytes(cv::Size viewSize, int layers, int octaves, int firstOctave,
                       bool detectionOnly);

/// Peak bytes of detectAndCompute beyond the caller's input, for `batch` slices
/// built at once:
///   grey light field (+ weights)           lightFieldBytes
///   + (batch + 2) detection pyramids        (the sliding window over slopes)
///   + batch * (full - detection pyramid + upsampled base)   while building
///   + the focal slices rendered ahead       (at least batch + 1 per pass)
///   + the slope survey's decimated views     (kept for the next call's survey).
struct MemoryEstimate {
  double lightFieldBytes = 0;
  double windowSliceBytes = 0;  // one detection-only pyramid
  double buildBytes = 0;        // extra while one slice is being built
  double focalSliceBytes = 0;   // one focal slice
  int slicesPerPass = 1;        // focal slices rendered in one pass, at least
  double surveyBytes = 0;       // the survey's decimated light fields (surveyMemoryBytes)
  bool nearLimit = false;       // the call's total is close to its memory limit

  int slicesAhead(int batch) const { return std::max(slicesPerPass, batch + 1); }
  double total(int batch) const {
    return lightFieldBytes + (batch + 2) * windowSliceBytes + batch * buildBytes +
           slicesAhead(batch) * focalSliceBytes + surveyBytes;
  }
};

/// The estimate's per-slice parts for views of `viewSize` (lightFieldBytes left 0):
/// what buildScaleSpace, the slice pool and the focal slices rendered ahead hold.
MemoryEstimate sliceMemory(cv::Size viewSize, int layers, int octaves, int firstOctave);

/// Physical memory this process can still use, in bytes: on Linux MemAvailable from
/// /proc/meminfo, capped by the cgroup (v2 or v1) limit minus current usage; 0 when
/// unknown (other systems), meaning no automatic limit.
double availableMemoryBytes();

}  // namespace detail
}  // namespace liff
