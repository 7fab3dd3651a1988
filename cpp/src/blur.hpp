// The scale space's hot kernels: SIFT's separable Gaussian blur with the DoG fused
// into it, and the 2x bilinear upsample of the first octave, each computing a range
// of output rows so that one image can be split over threads with no overlap.
#pragma once

#include <opencv2/core.hpp>

#include <vector>

namespace liff {
namespace detail {

/// One half of a symmetric Gaussian kernel: taps[i] weights the samples i pixels
/// either side of the centre (taps[0] the centre itself). The taps are
/// cv::getGaussianKernel(2 r + 1, sigma, CV_32F) with cv::GaussianBlur's size for
/// float images, 2 r + 1 = round(8 sigma + 1) | 1, so a blur with them is
/// cv::GaussianBlur's up to float rounding.
struct GaussianTaps {
  std::vector<float> taps;
  int radius() const { return int(taps.size()) - 1; }
};
GaussianTaps gaussianTaps(double sigma);

/// Rows [rowBegin, rowEnd) of the separable Gaussian blur of `src` (CV_32F) into
/// `dst` (CV_32F, src's size, allocated by the caller), borders reflected as
/// BORDER_REFLECT_101 (cv::GaussianBlur's default):
///
///   dst(y, x) = sum_{|j| <= rx} kx_|j| sum_{|i| <= ry} ky_|i| src(y + i, x + j)
///
/// computed column first, with the symmetric taps paired, k_i (a + b): each output row
/// is one vertical pass over 2 ry + 1 source rows and one horizontal pass over that
/// row, so stripes of rows share no work and any split gives the same result. With
/// `dog` (CV_32F, src's size), also dog(y, x) = dst(y, x) - src(y, x), the difference
/// of two consecutive Gaussians of the scale space, written while the row is in cache.
/// `src` and `dst` must not overlap.
void gaussianBlurRows(const cv::Mat& src, cv::Mat& dst, const GaussianTaps& kx,
                      const GaussianTaps& ky, int rowBegin, int rowEnd, cv::Mat* dog = nullptr);

/// Rows [rowBegin, rowEnd) of `src` (CV_32F, H x W) upsampled 2x bilinearly into `dst`
/// (CV_32F, 2H x 2W, allocated by the caller), as cv::resize(INTER_LINEAR) does it:
/// output pixel X samples the input at X / 2 - 1/4, so each output pixel is
/// 3/4 of its nearer input pixel and 1/4 of the farther one along each axis, and the
/// outermost output rows and columns copy the outermost input ones.
void upsample2xRows(const cv::Mat& src, cv::Mat& dst, int rowBegin, int rowEnd);

}  // namespace detail
}  // namespace liff
