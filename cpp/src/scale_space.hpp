// SIFT's Gaussian and DoG scale space of one focal slice, built as cv::SIFT builds it.
#pragma once

#include <opencv2/core.hpp>

#include <cmath>
#include <memory>
#include <mutex>
#include <vector>

namespace liff {
namespace detail {

/// SIFT's first octave (the firstOctave parameter's default): -1 = the slice is
/// upsampled 2x before the first blur (as cv::SIFT); 0 = the slice at its own size.
constexpr int kDefaultFirstOctave = -1;
/// Blur assumed already present in the input image (Lowe's 0.5).
constexpr float kInitialSigma = 0.5f;

/// Number of octaves for a view of `size`, as cv::SIFT: round(log2(min side of the
/// base) - 2) - firstOctave, the base being the view scaled by 2^-firstOctave.
int numOctaves(cv::Size viewSize, int firstOctave = kDefaultFirstOctave);

/// Gaussian and DoG pyramids of one slice. Octave o (0-based) holds images of the
/// base size / 2^o; gaussian(o, i) for i in [0, layers + 2], dog(o, i) for i in
/// [0, layers + 1].
struct ScaleSpace {
  int octaves = 0;
  int layers = 0;  // nOctaveLayers
  int firstOctave = kDefaultFirstOctave;
  std::vector<cv::Mat> gaussians;
  std::vector<cv::Mat> dogs;

  const cv::Mat& gaussian(int o, int i) const { return gaussians[o * (layers + 3) + i]; }
  const cv::Mat& dog(int o, int i) const { return dogs[o * (layers + 2) + i]; }
};

/// Memory one slice's build reuses from the last: the upsampled base and the three
/// Gaussian layers per octave a detection-only pyramid does not keep (sized for
/// octave 0; smaller octaves use the start of the same buffers).
struct BuildScratch {
  cv::Mat base;
  cv::Mat transient[3];
};

/// One slice's part in buildScaleSpaces: its focal slice (CV_32F), the blur the
/// focal stack's interpolation left in it (`variance`, per axis, view pixels^2; 0 for
/// a single view), the pyramid to fill (its images' memory is reused when their sizes
/// match: a pyramid of an earlier slice of the same light field) and, optionally,
/// scratch memory for the images a detection-only pyramid does not keep.
struct SliceBuild {
  const cv::Mat* slice;
  cv::Vec2d variance;
  ScaleSpace* space;
  BuildScratch* scratch = nullptr;
};

/// Builds the pyramids of several slices together, as cv::SIFT builds one:
/// base = upsample 2x (bilinear; firstOctave -1, else the slice itself) and blur to sigma; each octave blurs incrementally,
///   sigma_i^2 = (k^i sigma)^2 - (k^(i-1) sigma)^2,  k = 2^(1 / layers),
/// starts from layer `layers` of the previous octave decimated 2x, and
/// DoG_i = G_(i+1) - G_i (made by the blur that makes G_(i+1)).
///
/// `targetVariance` is the largest interpolation blur over all slices: the base blur
/// tops each slice up to it, so every slice carries the same blur, and counts it as
/// blur already present:
///   base^2 = max(sigma^2 - (u * 0.5)^2 - u^2 * target, 0.01) + u^2 * (target - variance),
/// u = 2^-firstOctave being the upsampling.
///
/// With `detectionOnly`, the Gaussians no detected keypoint can use (layers 0,
/// layers + 1 and layers + 2 of each octave) are not kept: they are made in the
/// slice's scratch (or allocated, without one) and dropped once the DoGs are made.
///
/// The slices advance in step: each image of the pyramid is one parallel loop over
/// every slice's row stripes, so all threads have work whatever the number of slices
/// (one slice alone included); the small octaves (at most two stripes, 64 rows) are
/// one loop in all, a slice's all in one task (under 1% of a pyramid whose first octave
/// has 500 rows or more; a loop per image cost more in starting and joining threads).
/// Each row is computed the same way whatever the split, so the result does not depend
/// on the number of threads or of slices built at once.
void buildScaleSpaces(const std::vector<SliceBuild>& builds, int layers, double sigma,
                      int octaves, int firstOctave, cv::Vec2d targetVariance,
                      bool detectionOnly);

/// buildScaleSpaces for one slice.
void buildScaleSpace(const cv::Mat& slice, int layers, double sigma, int octaves,
                     cv::Vec2d variance, cv::Vec2d targetVariance, bool detectionOnly,
                     ScaleSpace& space, BuildScratch* scratch = nullptr,
                     int firstOctave = kDefaultFirstOctave);

/// Pyramids and build scratch handed back by finished slices, for the next ones of
/// the same detection pass: the pass then allocates, and the kernel zero-fills, its
/// largest buffers once instead of once per slice. Thread-safe.
class ScaleSpacePool {
 public:
  /// A pyramid released earlier, or a new empty one.
  std::shared_ptr<ScaleSpace> takeSpace();
  /// Gives back a pyramid nobody else holds (one still shared elsewhere is dropped).
  void giveSpace(std::shared_ptr<ScaleSpace> space);
  std::unique_ptr<BuildScratch> takeScratch();
  void giveScratch(std::unique_ptr<BuildScratch> scratch);

 private:
  std::mutex mutex_;
  std::vector<std::shared_ptr<ScaleSpace>> spaces_;
  std::vector<std::unique_ptr<BuildScratch>> scratches_;
};

/// Octave-image coordinate -> centre-view pixel coordinate, for octave index o
/// (0-based) of a pyramid whose first octave is `first`. Octave pixel x sits at base
/// pixel x * 2^o (decimation keeps even pixels); a 2^-f bilinear upsample puts base
/// pixel X at view pixel X * 2^f + (2^f - 1) / 2 (pixel centres at integers), i.e.
/// X / 2 - 1/4 for f = -1 and X for f = 0. cv::SIFT omits the -1/4; we keep it so
/// positions are unbiased.
inline float octaveToView(float x, int o, int first) {
  const float f = std::ldexp(1.f, first);
  return x * std::ldexp(1.f, o + first) + 0.5f * (f - 1.f);
}
/// Inverse of octaveToView.
inline float viewToOctave(float x, int o, int first) {
  const float f = std::ldexp(1.f, first);
  return (x - 0.5f * (f - 1.f)) / std::ldexp(1.f, o + first);
}

}  // namespace detail
}  // namespace liff
