// SIFT orientation assignment and the 128-D descriptor, on one Gaussian image of
// a focal slice's scale space (Lowe 2004, with cv::SIFT's constants).
#pragma once

#include <opencv2/core.hpp>

namespace liff {
namespace detail {

/// Bins of the orientation histogram (10 degrees each).
constexpr int kOrientationBins = 36;
/// Gaussian window of the orientation histogram, in units of the keypoint scale.
constexpr float kOrientationSigmaFactor = 1.5f;
/// Radius of the orientation window, in units of the keypoint scale (3 sigma).
constexpr float kOrientationRadius = 3 * kOrientationSigmaFactor;
/// Secondary peaks within this fraction of the highest one make extra keypoints.
constexpr float kOrientationPeakRatio = 0.8f;
/// Descriptor grid: kDescriptorWidth x kDescriptorWidth cells of kDescriptorBins bins.
constexpr int kDescriptorWidth = 4;
constexpr int kDescriptorBins = 8;
constexpr int kDescriptorSize = kDescriptorWidth * kDescriptorWidth * kDescriptorBins;
/// Width of one descriptor cell, in units of the keypoint scale.
constexpr float kDescriptorCellFactor = 3.f;
/// SIFT clamps normalised descriptor entries at this value, then renormalises.
constexpr float kDescriptorClamp = 0.2f;
/// Unit-norm descriptors are scaled by this and saturated to [0, 255], as cv::SIFT does
/// for both its float and its uint8 output.
constexpr float kDescriptorIntScale = 512.f;

/// Smoothed 36-bin histogram of gradient orientations around `centre` (integer
/// pixel of `image`) within `radius`, weighted by magnitude and a Gaussian of
/// `sigma`. Returns the highest bin value.
float orientationHistogram(const cv::Mat& image, cv::Point centre, int radius, float sigma,
                           float* hist);

/// Raw (unnormalised) 4x4x8 descriptor at `point` (sub-pixel, image coordinates),
/// rotated by `angleDegrees` (counter-clockwise as seen on screen: 360 minus the
/// keypoint's angle, as cv::SIFT), of a
/// keypoint of scale `scale` (sigma in this image's pixels).
void rawDescriptor(const cv::Mat& image, cv::Point2f point, float angleDegrees, float scale,
                   float* raw);

/// Normalises a raw descriptor as SIFT (L2, clamp 0.2, L2 again) and, if rootSift,
/// L1-normalises and takes the square root; writes round(512 * d) saturated to
/// [0, 255] into `row` (CV_32F or CV_8U, kDescriptorSize columns).
void finishDescriptor(float* raw, bool rootSift, cv::Mat row);

struct ScaleSpace;

/// The descriptor of `keypoint` (centre-view pixels, octave packed as cv::SIFT, size a
/// diameter, angle in degrees; any angle is reduced to [0, 360)) on the Gaussian image
/// of its octave and layer in `space`, finished (finishDescriptor) into `row`. The
/// keypoint's octave and layer must exist in `space`.
void describeKeypoint(const ScaleSpace& space, const cv::KeyPoint& keypoint, bool rootSift,
                      cv::Mat row);

}  // namespace detail
}  // namespace liff
