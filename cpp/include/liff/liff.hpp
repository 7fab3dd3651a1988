// liff: Light Field Features in scale and depth (Dansereau, Girod, Wetzstein).
//
// Public C++ API. A light field arrives as one stacked cv::Mat:
//   * 4-D, sizes {T, S, V, U}: view row, view column, pixel row, pixel column;
//     1 channel (grey), 2 (grey + alpha), 3 (BGR, converted to grey by luminance)
//     or 4 (BGRA); alpha is a per-sample validity weight a >= 0 and the focal
//     stack becomes sum(a L) / sum(a);
//     depth CV_8U (/255), CV_16U (/65535), CV_32F or CV_64F (taken as given);
//   * 2-D (V x U, 1 to 4 channels): a single view, i.e. a 1x1 light field, for
//     which LiFF behaves as SIFT.
//
// Slope convention: a scene point at (x, y) in the centre view appears at
//   (x - slope * (s - s_c), y - slope * (t - t_c))   in view (t, s),
// with s_c = (S - 1) / 2 and t_c = (T - 1) / 2. This equals the disparity of the
// HCI 4D light field benchmark (pixels per view step).
//
// Keypoints are cv::SIFT-compatible: pt in centre-view pixels (integer
// coordinates at pixel centres), size a diameter, angle in degrees, response the
// absolute DoG contrast, octave packed as cv::SIFT packs it. The slope travels in
// class_id = round(slope * kSlopeScale); read it back with keypointSlope().
#pragma once

#include <limits>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>  // OpenCV 5 keeps this as a compatibility header

#include <liff/parameter_file.hpp>
#include <liff/parameters.hpp>

namespace liff {

/// Fixed-point scale of the slope stored in cv::KeyPoint::class_id.
constexpr double kSlopeScale = 65536.0;

/// The slope (pixels per view step) stored in a keypoint's class_id.
double keypointSlope(const cv::KeyPoint& keypoint);

/// class_id that encodes a slope: round(slope * kSlopeScale).
int slopeToClassId(double slope);

/// Working memory. The detector keeps the large buffers a call frees (the grey light
/// field, focal slices, scale spaces: every Mat of a page (4 KiB) or more of the system
/// OpenCV, which it allocates through its own allocator from its first call on) and
/// reuses them in the next call, in any thread, so a second call on a light field of
/// the same size takes almost no page faults. In use and kept together stay within
/// twice what the process had in use at once so far (the largest call), and a call's
/// memory limit counts kept memory as available. releaseWorkingMemory() frees what is kept now; setWorkingMemoryReuse
/// (false) frees it and keeps nothing from then on.
void releaseWorkingMemory();
/// Bytes kept for reuse now (freed by the last calls, not in use).
size_t keptWorkingMemoryBytes();
void setWorkingMemoryReuse(bool enabled);
bool getWorkingMemoryReuse();
/// Bytes of physical memory this process can still use, as the detector's default
/// memory limit counts them: on Linux MemAvailable (/proc/meminfo), capped by the room
/// under the cgroup's (v2 or v1) limit, plus the working memory kept for reuse; 0 when
/// unknown (other systems: no automatic limit).
double availableMemoryBytes();

/// Share of a call's features at a hand-set end of the slope range above which the
/// detector looks for structure beyond that end (SlopeRangeReport::surveyedSlopes).
constexpr double kRangeEndShare = 0.05;

/// Largest automatic slope (SlopeRangeReport::automaticReach, pixels per view step) below
/// which scenes often reach beyond it (camera arrays, gantries, long rows of views):
/// there a call that finds no feature is warned of.
constexpr double kSmallReach = 3.0;

/// What the last completed detect/detectAndCompute/compute call of a detector found out about its
/// own slope range (docs/SLOPES.md): the facts the Python package's SlopeRangeWarning
/// messages are made of, computed by the core during the call. Slopes are in pixels per
/// view step (the slope convention above).
struct SlopeRangeReport {
  /// Slopes of every focal slice the call built, increasing, and of the slices it searched
  /// for extrema (the others were built as the neighbours of searched ones).
  std::vector<double> slicesUsed, searchedSlopes;
  /// The light field's sizes.
  int T = 0, S = 0, V = 0, U = 0;
  /// Whether the range was automatic (firstSlope = -inf and lastSlope = +inf).
  bool automaticRange = false;
  /// Largest |slope| the automatic range considers at an automatic end (docs/SLOPES.md,
  /// "Bound": a quarter of the smaller view side over the outermost views' distance, or up
  /// to 1 while they differ by half the view); NaN with a hand-set range (both ends finite)
  /// or where the automatic range runs no survey (one or two views along the longer axis).
  double automaticReach = std::numeric_limits<double>::quiet_NaN();
  /// The automatic range's survey ran and found no structure: the paper's [-1, 1] was
  /// searched.
  bool surveyFoundNothing = false;
  /// The automatic range's survey saw structure at or beyond +-automaticReach at an
  /// automatic end, which it does not consider: features there may be missed or reported
  /// at wrong slopes.
  bool structureBeyondReach = false;
  /// Features the call found before nfeatures' cut (retainBest) and returned after it.
  int featuresFound = 0, featuresReturned = 0;
  /// Returned features whose slope is the first (last) searched slope where that end is a
  /// finite, hand-set bound (within one class_id step, 1 / kSlopeScale); 0 otherwise.
  int featuresAtFirstSlope = 0, featuresAtLastSlope = 0;
  /// Where those features are more than kRangeEndShare of the returned ones: whether the
  /// automatic range's survey (docs/SLOPES.md) ran on the light field to find structure
  /// beyond the ends, and the slopes of the features it kept (structure the hand-set
  /// range may have cut; empty when it found none).
  bool endsSurveyed = false;
  std::vector<double> surveyedSlopes;
};

/// LiFF detector and descriptor: SIFT extended to the 4-D light field.
///
/// Every parameter of LIFF_PARAMETERS (liff/parameters.hpp) has a getter and a setter,
/// getName() / setName(value) (getNFeatures, setContrastThreshold, ...); a setter
/// throws cv::Exception (StsOutOfRange) naming the range expected.
class CV_EXPORTS_W LiFF : public cv::Feature2D {
 public:
  /// A detector with `parameters` (Parameters::check() applies). With the default
  /// firstSlope = -inf and lastSlope = +inf the focal stack's slopes are found from
  /// each light field (docs/SLOPES.md); finite values set them by hand.
  static cv::Ptr<LiFF> create(const Parameters& parameters);

  /// A detector with cv::SIFT's positional parameters followed by LiFF's (the
  /// meaning, unit and range of each are in LIFF_PARAMETERS; the defaults are
  /// Parameters').
  static cv::Ptr<LiFF> create(int nfeatures = Parameters().nfeatures,
                              int nOctaveLayers = Parameters().nOctaveLayers,
                              double contrastThreshold = Parameters().contrastThreshold,
                              double edgeThreshold = Parameters().edgeThreshold,
                              double sigma = Parameters().sigma,
                              double firstSlope = Parameters().firstSlope,
                              double lastSlope = Parameters().lastSlope,
                              int numSlopes = Parameters().numSlopes,
                              int descriptorType = Parameters().descriptorType,
                              bool rootSift = Parameters().rootSift,
                              int firstOctave = Parameters().firstOctave);

#define LIFF_DECLARE_ACCESSORS(Type, name, Name, value, help) \
  virtual void set##Name(Type name) = 0;                       \
  virtual Type get##Name() const = 0;
  LIFF_PARAMETERS(LIFF_DECLARE_ACCESSORS)
#undef LIFF_DECLARE_ACCESSORS

  virtual Parameters getParameters() const = 0;
  /// Sets every parameter at once; throws (leaving the detector unchanged) if one is
  /// out of range.
  virtual void setParameters(const Parameters& parameters) = 0;

  /// Memory detectAndCompute may use beyond its input, in megabytes (2^20 bytes).
  /// 0 (default) = automatic: the memory available when a call starts (Linux:
  /// MemAvailable, capped by the cgroup limit; no limit where unknown); +infinity =
  /// no limit. When the estimated need exceeds it, fewer slices are built at once;
  /// if even one at a time does not fit, the call throws cv::Error::StsNoMem naming
  /// the estimate and the limit, before allocating anything large. Not saved by write().
  virtual void setMemoryLimitMB(double megabytes) = 0;
  virtual double getMemoryLimitMB() const = 0;

  /// The slopes of the focal slices for a light field of T x S views with a finite
  /// slope range (resolves numSlopes = 0; a 1x1 light field has the single slope
  /// (firstSlope + lastSlope) / 2). With an automatic range the slopes depend on the
  /// light field's content: throws cv::Error::StsBadArg, use the overload below.
  virtual std::vector<double> slopesFor(int T, int S) const = 0;
  /// The slopes of the focal slices detection would build for `lightField` (as
  /// detectAndCompute takes it): for an automatic range this runs its survey
  /// (docs/SLOPES.md), which costs 13-44% of a detection in benchmarks/slopes.py (the
  /// most on small light fields).
  virtual std::vector<double> slopesFor(cv::InputArray lightField) = 0;

  /// The slopes of every focal slice the last completed detect/detectAndCompute/
  /// compute call of this object built, increasing (empty before the first call).
  virtual std::vector<double> getSlicesUsed() const = 0;
  /// The slopes of the slices that call searched for extrema: each keypoint's slope
  /// lies within half a slice spacing of one. The others were built only as the
  /// neighbours a searched slice is compared with.
  virtual std::vector<double> getSearchedSlopes() const = 0;
  /// What the last completed detect/detectAndCompute/compute call found out about its
  /// slope range (SlopeRangeReport; for compute(), its slices and the keypoints
  /// described); all defaults before the first call.
  virtual SlopeRangeReport getSlopeRangeReport() const = 0;

  cv::String getDefaultName() const override;

  /// Reads parameters from a FileStorage file (as written by write(fileName) or
  /// save()) through openParameterFile: a file too large or nested too deep, or not a
  /// regular file, throws cv::Exception instead of reaching OpenCV's parser. Hides
  /// cv::Feature2D::read(fileName), which is not virtual: call it through a LiFF.
  void read(const cv::String& fileName);
  using cv::Feature2D::read;
};

}  // namespace liff
