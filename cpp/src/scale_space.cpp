#include "scale_space.hpp"

#include <opencv2/imgproc.hpp>

#include <cmath>

namespace liff {
namespace detail {
namespace {

// Rows per parallel task of a blur. Each stripe also filters the kernel radius (up to
// 12 rows at octave -1) above and below it horizontally, so stripes are kept tall.
constexpr int kBlurRows = 64;

// cv::GaussianBlur, split into row stripes run in parallel when `rowParallel`. OpenCV
// filters a sub-matrix with the pixels of its parent beyond the stripe, so the result
// is identical to one call on the whole image, whatever the split.
void gaussianBlur(const cv::Mat& src, cv::Mat& dst, double sigmaX, double sigmaY,
                  bool rowParallel) {
  if (!rowParallel || src.rows < 2 * kBlurRows) {
    cv::GaussianBlur(src, dst, cv::Size(), sigmaX, sigmaY);
    return;
  }
  dst.create(src.size(), src.type());
  const int tasks = (src.rows + kBlurRows - 1) / kBlurRows;
  cv::parallel_for_(cv::Range(0, tasks), [&](const cv::Range& range) {
    for (int task = range.start; task < range.end; ++task) {
      const int r0 = task * kBlurRows, r1 = std::min(src.rows, r0 + kBlurRows);
      cv::Mat stripe = dst.rowRange(r0, r1);
      cv::GaussianBlur(src.rowRange(r0, r1), stripe, cv::Size(), sigmaX, sigmaY);
    }
  });
}

}  // namespace

int numOctaves(cv::Size viewSize) {
  const double baseMin = std::min(viewSize.width, viewSize.height) * std::ldexp(1.0, -kFirstOctave);
  return std::max(0, cvRound(std::log2(baseMin) - 2) - kFirstOctave);
}

namespace {

// A `size` image over the start of `buffer`, which must hold at least that many floats.
cv::Mat imageIn(const cv::Mat& buffer, cv::Size size) {
  CV_Assert(buffer.isContinuous() && buffer.total() >= size_t(size.area()));
  return cv::Mat(size, CV_32F, buffer.data);
}

}  // namespace

void buildScaleSpace(const cv::Mat& slice, int layers, double sigma, int octaves,
                     cv::Vec2d variance, cv::Vec2d targetVariance, bool detectionOnly,
                     bool rowParallel, ScaleSpace& space, BuildScratch* scratch) {
  CV_Assert(slice.type() == CV_32F && layers >= 1 && octaves >= 1);
  space.octaves = octaves;
  space.layers = layers;
  space.gaussians.resize(size_t(octaves) * (layers + 3));
  space.dogs.resize(size_t(octaves) * (layers + 2));

  // Base: upsample 2x (kFirstOctave = -1), then blur from the assumed 2 * 0.5 (plus
  // the interpolation blur every slice is topped up to) to sigma.
  cv::Mat localBase;
  cv::Mat& base = scratch ? scratch->base : localBase;
  const double upsample = std::ldexp(1.0, -kFirstOctave), up2 = upsample * upsample;
  double blur[2];
  for (int axis = 0; axis < 2; ++axis) {
    const double present2 = kInitialSigma * kInitialSigma * up2 + up2 * targetVariance[axis];
    const double topUp = up2 * std::max(0.0, targetVariance[axis] - variance[axis]);
    blur[axis] = std::sqrt(std::max(sigma * sigma - present2, 0.01) + topUp);
  }
  cv::resize(slice, base, cv::Size(), upsample, upsample, cv::INTER_LINEAR);
  const cv::Size baseSize = base.size();

  // Layers not kept in a detection-only pyramid live in the scratch buffers.
  const bool transient = detectionOnly && scratch;
  if (transient)
    for (cv::Mat& buffer : scratch->transient) buffer.create(baseSize, CV_32F);
  auto slot = [&](int i) -> cv::Mat* {
    if (!transient) return nullptr;
    if (i == 0) return &scratch->transient[0];
    if (i == layers + 1) return &scratch->transient[1];
    if (i == layers + 2) return &scratch->transient[2];
    return nullptr;
  };

  // Incremental blurs: sigma_i^2 = (k^i sigma)^2 - (k^(i-1) sigma)^2.
  std::vector<double> increment(layers + 3);
  const double k = std::pow(2.0, 1.0 / layers);
  increment[0] = sigma;
  for (int i = 1; i < layers + 3; ++i) {
    const double previous = std::pow(k, double(i - 1)) * sigma, total = previous * k;
    increment[i] = std::sqrt(total * total - previous * previous);
  }

  for (int o = 0; o < octaves; ++o) {
    const cv::Size size(baseSize.width >> o, baseSize.height >> o);
    for (int i = 0; i < layers + 3; ++i) {
      cv::Mat& dst = space.gaussians[size_t(o) * (layers + 3) + i];
      if (const cv::Mat* buffer = slot(i)) dst = imageIn(*buffer, size);
      if (o == 0 && i == 0) {
        gaussianBlur(base, dst, blur[0], blur[1], rowParallel);
      } else if (i == 0) {
        // Layer `layers` of the previous octave has twice the base sigma: decimate it.
        const cv::Mat& src = space.gaussian(o - 1, layers);
        cv::resize(src, dst, cv::Size(src.cols / 2, src.rows / 2), 0, 0, cv::INTER_NEAREST);
      } else {
        gaussianBlur(space.gaussian(o, i - 1), dst, increment[i], increment[i], rowParallel);
      }
    }
    for (int i = 0; i < layers + 2; ++i)
      cv::subtract(space.gaussian(o, i + 1), space.gaussian(o, i),
                   space.dogs[size_t(o) * (layers + 2) + i]);
    if (detectionOnly)  // keypoints sit in layers [1, layers]; the next octave needs `layers`
      for (int i : {0, layers + 1, layers + 2})
        space.gaussians[size_t(o) * (layers + 3) + i].release();
  }
}

std::shared_ptr<ScaleSpace> ScaleSpacePool::takeSpace() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (spaces_.empty()) return std::make_shared<ScaleSpace>();
  std::shared_ptr<ScaleSpace> space = std::move(spaces_.back());
  spaces_.pop_back();
  return space;
}

void ScaleSpacePool::giveSpace(std::shared_ptr<ScaleSpace> space) {
  if (!space || space.use_count() != 1) return;
  std::lock_guard<std::mutex> lock(mutex_);
  spaces_.push_back(std::move(space));
}

std::unique_ptr<BuildScratch> ScaleSpacePool::takeScratch() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (scratches_.empty()) return std::make_unique<BuildScratch>();
  std::unique_ptr<BuildScratch> scratch = std::move(scratches_.back());
  scratches_.pop_back();
  return scratch;
}

void ScaleSpacePool::giveScratch(std::unique_ptr<BuildScratch> scratch) {
  std::lock_guard<std::mutex> lock(mutex_);
  scratches_.push_back(std::move(scratch));
}

}  // namespace detail
}  // namespace liff
