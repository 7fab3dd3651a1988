// Memory the detector will need, and memory the machine has, so that a light field
// too large fails early with a clear error instead of an out-of-memory kill.
#pragma once

#include <opencv2/core.hpp>

#include <algorithm>
#include <climits>

namespace liff {
class LiFF;
namespace detail {

/// Bytes of one slice's Gaussian and DoG pyramids (CV_32F, the first octave
/// upsampled 2^-firstOctave times): per octave the images halve; a full pyramid
/// holds layers + 3 Gaussians and layers + 2 DoGs per octave, a detection-only one
/// keeps `layers` Gaussians.
double scaleSpaceBytes(cv::Size viewSize, int layers, int octaves, int firstOctave,
                       bool detectionOnly);

/// Keypoints a detection is assumed to find, per pixel of its first octave (the view
/// upsampled 2^-firstOctave times): the densest content measured (smoothed noise of 1 to
/// 2 px, single images and light fields, firstOctave -1 and 0) gives one per 85 to 90;
/// photos and light-field captures give one per 1,000 or more (benchmarks/memory.py).
constexpr double kKeypointsPerPixel = 1.0 / 100;
/// Bytes of keypoint records per keypoint besides its descriptors: the core's vectors of
/// cv::KeyPoint and the Python layer's rows and cv2.KeyPoint objects.
constexpr double kKeypointRecordBytes = 256;
/// Each call's small allocations: the threads' row buffers and stacks, the buffers
/// under kKeptBufferMinBytes, the Python layer's (2 to 6 MB measured).
constexpr double kCallOverheadBytes = 3.0 * 1024 * 1024;

/// Peak bytes of one call beyond the caller's input, for `batch` slices built at once.
/// Each term is a set of buffers the call holds together at its peak, while a batch of
/// slices is being built (cpp/src/slice_window.cpp, scale_space.cpp); the core's
/// working memory (working_memory.hpp) keeps a freed buffer for the next one of its
/// size, so a buffer counts from its first allocation to the end of the call:
///
///   lightFieldBytes                    the grey float light field (+ alpha weights)
///   + heldSlices(batch) * sliceBytes   the scale spaces held: detection, a window of
///                                      the batch and its two slope neighbours
///                                      (detection-only pyramids); compute(), the batch
///                                      (full pyramids)
///   + building(batch) * scratchBytes   each slice being built: the upsampled base
///                                      (firstOctave -1) and, for detection, the three
///                                      Gaussian layers per octave it does not keep,
///                                      each a first-octave image (BuildScratch)
///   + focalSlices(batch) * focalSliceBytes   the focal slices rendered ahead
///   + surveyBytes                      the automatic range's survey: its decimated
///                                      light fields, kept for the next call's survey
///                                      (its detection's own buffers are smaller than
///                                      the slices' and are reused by them)
///   + keypoints * keypointBytes        each keypoint's descriptor twice (the block the
///                                      detection writes it into, and the returned copy;
///                                      compute(): three times) and its records;
///                                      detection assumes kKeypointsPerPixel, compute()
///                                      knows the count
///   + kCallOverheadBytes
///
/// The slice counts are at most planSlices: a single view has one slice, a finite
/// range the slices of its uniform plan; an automatic range's plan is not known before
/// its survey, so its counts are not capped.
struct MemoryEstimate {
  double lightFieldBytes = 0;
  double sliceBytes = 0;       // one held pyramid
  double scratchBytes = 0;     // one slice's build scratch
  double focalSliceBytes = 0;  // one focal slice
  int slicesPerPass = 1;       // focal slices rendered in one pass, at least (detection)
  int planSlices = INT_MAX;    // the most slices the call's plan can have
  bool describing = false;     // compute(): the given keypoints' slices, no window
  double surveyBytes = 0;      // surveyMemoryBytes
  double keypoints = 0;        // keypoints described (assumed, for detection)
  double keypointBytes = 0;    // descriptors and records of one keypoint
  bool nearLimit = false;      // the call's total is close to its memory limit

  /// Focal slices the detection renders ahead in slope order (FocalSliceSource).
  int slicesAhead(int batch) const { return std::max(slicesPerPass, batch + 1); }
  int heldSlices(int batch) const { return std::min(describing ? batch : batch + 2, planSlices); }
  int building(int batch) const { return std::min(batch, planSlices); }
  int focalSlices(int batch) const {
    return std::min(describing ? batch : slicesAhead(batch), planSlices);
  }
  double keypointTotal() const { return keypoints * keypointBytes; }
  double total(int batch) const {
    return lightFieldBytes + heldSlices(batch) * sliceBytes + building(batch) * scratchBytes +
           focalSlices(batch) * focalSliceBytes + surveyBytes + keypointTotal() +
           kCallOverheadBytes;
  }
};

/// The estimate's parts for views of `viewSize` (lightFieldBytes, surveyBytes and
/// planSlices left to the caller): what buildScaleSpace, the slice pool and the focal
/// slices hold, and the keypoints: for compute() (`describing`: full pyramids, no
/// window) the `described` given ones, for detection kKeypointsPerPixel of the first
/// octave; `descriptorBytes` per descriptor.
MemoryEstimate sliceMemory(cv::Size viewSize, int layers, int octaves, int firstOctave,
                           bool describing, size_t described, int descriptorBytes);

/// The estimate `detector`'s last detect/detectAndCompute/compute call checked its
/// limit with, and the slices it built at once (`batch`); 0 before the first call or
/// for another detector. For the tests and benchmarks/memory.py, which compare it with
/// the memory the call took.
MemoryEstimate lastMemoryEstimate(const LiFF& detector, int& batch);

/// Physical memory this process can still use, in bytes: on Linux MemAvailable from
/// /proc/meminfo, capped by the cgroup (v2 or v1) limit minus current usage; 0 when
/// unknown (other systems), meaning no automatic limit.
double availableMemoryBytes();

}  // namespace detail
}  // namespace liff
