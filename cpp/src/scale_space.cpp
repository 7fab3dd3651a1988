#include "scale_space.hpp"

#include <algorithm>
#include <cmath>

#include "blur.hpp"
#include "profile.hpp"

namespace liff {
namespace detail {
int numOctaves(cv::Size viewSize, int firstOctave) {
  const double baseMin = std::min(viewSize.width, viewSize.height) * std::ldexp(1.0, -firstOctave);
  return std::max(0, cvRound(std::log2(baseMin) - 2) - firstOctave);
}

namespace {

// A `size` image over the start of `buffer`, which must hold at least that many floats.
cv::Mat imageIn(const cv::Mat& buffer, cv::Size size) {
  CV_Assert(buffer.isContinuous() && buffer.total() >= size_t(size.area()));
  return cv::Mat(size, CV_32F, buffer.data);
}

}  // namespace

namespace {

// Rows of one image per parallel task. Stripes share no work (gaussianBlurRows), so
// they can be short; 32 rows keep the per-task overhead small against a stripe's
// work even in the first octave of a small view.
constexpr int kRowsPerTask = 32;

// Octaves of at most this many rows (two stripes) and this many rows squared of pixels
// are built a slice at a time, all of them in one task (buildScaleSpaces).
constexpr int kTailOctaveRows = 2 * kRowsPerTask;

// Runs step(build, rowBegin, rowEnd) over every build's rows [0, rows(build)) in
// stripes of kRowsPerTask, all in one parallel loop.
template <class Rows, class Step>
void forEachStripe(int builds, Rows rows, Step step) {
  std::vector<cv::Vec3i> tasks;  // (build, rowBegin, rowEnd)
  for (int b = 0; b < builds; ++b)
    for (int r0 = 0, n = rows(b); r0 < n; r0 += kRowsPerTask)
      tasks.push_back({b, r0, std::min(n, r0 + kRowsPerTask)});
  parallelFor("scale space", cv::Range(0, int(tasks.size())), [&](const cv::Range& range) {
    StageTimer timer(kScaleSpace);
    for (int t = range.start; t < range.end; ++t) step(tasks[t][0], tasks[t][1], tasks[t][2]);
  });
}

}  // namespace

void buildScaleSpaces(const std::vector<SliceBuild>& builds, int layers, double sigma,
                      int octaves, int firstOctave, cv::Vec2d targetVariance,
                      bool detectionOnly) {
  CV_Assert(layers >= 1 && octaves >= 1 && (firstOctave == -1 || firstOctave == 0));
  const int n = int(builds.size());
  if (n == 0) return;
  const int upsample = 1 << -firstOctave, up2 = upsample * upsample;
  const cv::Size viewSize = builds[0].slice->size();
  const cv::Size baseSize(viewSize.width * upsample, viewSize.height * upsample);

  // Base: upsample 2x (firstOctave -1) or the slice itself (0), then blur from the assumed 2 * 0.5 (plus
  // the interpolation blur every slice is topped up to) to sigma. The blur differs
  // per slice, by its own interpolation blur.
  std::vector<GaussianTaps> baseX(n), baseY(n);
  std::vector<cv::Mat> localBase(n);
  std::vector<cv::Mat*> base(n);
  for (int b = 0; b < n; ++b) {
    const SliceBuild& build = builds[b];
    CV_Assert(build.slice->type() == CV_32F && build.slice->size() == viewSize);
    ScaleSpace& space = *build.space;
    space.octaves = octaves;
    space.layers = layers;
    space.firstOctave = firstOctave;
    space.gaussians.resize(size_t(octaves) * (layers + 3));
    space.dogs.resize(size_t(octaves) * (layers + 2));
    for (int axis = 0; axis < 2; ++axis) {
      const double present2 = kInitialSigma * kInitialSigma * up2 + up2 * targetVariance[axis];
      const double topUp = up2 * std::max(0.0, targetVariance[axis] - build.variance[axis]);
      (axis == 0 ? baseX : baseY)[b] =
          gaussianTaps(std::sqrt(std::max(sigma * sigma - present2, 0.01) + topUp));
    }
    if (upsample == 1) {
      base[b] = const_cast<cv::Mat*>(build.slice);  // read only: the blur's source
    } else {
      base[b] = build.scratch ? &build.scratch->base : &localBase[b];
      base[b]->create(baseSize, CV_32F);
    }
    if (detectionOnly && build.scratch)
      for (cv::Mat& buffer : build.scratch->transient) buffer.create(baseSize, CV_32F);
  }
  if (upsample == 2)
    forEachStripe(n, [&](int) { return baseSize.height; }, [&](int b, int r0, int r1) {
      upsample2xRows(*builds[b].slice, *base[b], r0, r1);
    });

  // Incremental blurs: sigma_i^2 = (k^i sigma)^2 - (k^(i-1) sigma)^2.
  std::vector<GaussianTaps> increment(layers + 3);
  const double k = std::pow(2.0, 1.0 / layers);
  for (int i = 1; i < layers + 3; ++i) {
    const double previous = std::pow(k, double(i - 1)) * sigma, total = previous * k;
    increment[i] = gaussianTaps(std::sqrt(total * total - previous * previous));
  }

  // Layers a detection-only pyramid does not keep live in the scratch buffers.
  auto transientSlot = [&](const SliceBuild& build, int i) -> cv::Mat* {
    if (!detectionOnly || !build.scratch) return nullptr;
    if (i == 0) return &build.scratch->transient[0];
    if (i == layers + 1) return &build.scratch->transient[1];
    if (i == layers + 2) return &build.scratch->transient[2];
    return nullptr;
  };
  auto allocate = [&](int o, int i) {
    const cv::Size size(baseSize.width >> o, baseSize.height >> o);
    for (const SliceBuild& build : builds) {
      ScaleSpace& space = *build.space;
      cv::Mat& dst = space.gaussians[size_t(o) * (layers + 3) + i];
      if (const cv::Mat* buffer = transientSlot(build, i))
        dst = imageIn(*buffer, size);
      else
        dst.create(size, CV_32F);
      if (i > 0) space.dogs[size_t(o) * (layers + 2) + i - 1].create(size, CV_32F);
    }
  };
  // Rows [r0, r1) of Gaussian i of octave o of build b (and of the DoG it ends).
  auto layerRows = [&](int b, int o, int i, int r0, int r1) {
    ScaleSpace& space = *builds[b].space;
    cv::Mat& dst = space.gaussians[size_t(o) * (layers + 3) + i];
    if (o == 0 && i == 0) {
      gaussianBlurRows(*base[b], dst, baseX[b], baseY[b], r0, r1);
    } else if (i == 0) {
      // Layer `layers` of the previous octave has twice the base sigma: decimate it
      // (even rows and columns, as cv::resize INTER_NEAREST by 1/2).
      const cv::Mat& src = space.gaussian(o - 1, layers);
      for (int y = r0; y < r1; ++y) {
        const float* in = src.ptr<float>(2 * y);
        float* out = dst.ptr<float>(y);
        for (int x = 0; x < dst.cols; ++x) out[x] = in[2 * x];
      }
    } else {
      cv::Mat& dog = space.dogs[size_t(o) * (layers + 2) + i - 1];
      gaussianBlurRows(space.gaussian(o, i - 1), dst, increment[i], increment[i], r0, r1, &dog);
    }
  };
  auto dropTransients = [&](int o) {
    if (detectionOnly)  // keypoints sit in layers [1, layers]; the next octave needs `layers`
      for (const SliceBuild& build : builds)
        for (int i : {0, layers + 1, layers + 2})
          build.space->gaussians[size_t(o) * (layers + 3) + i].release();
  };

  // Octaves of at least kTailOctaveRows rows: each image one parallel loop over every
  // slice's row stripes.
  auto small = [&](int o) {
    const cv::Size size(baseSize.width >> o, baseSize.height >> o);
    return size.height <= kTailOctaveRows && size.area() <= kTailOctaveRows * kTailOctaveRows;
  };
  int tail = 0;
  while (tail < octaves && !small(tail)) ++tail;
  for (int o = 0; o < tail; ++o) {
    for (int i = 0; i < layers + 3; ++i) {
      allocate(o, i);
      forEachStripe(n, [&](int) { return baseSize.height >> o; },
                    [&](int b, int r0, int r1) { layerRows(b, o, i, r0, r1); });
    }
    dropTransients(o);
  }
  // The smaller octaves, a slice's all in one task: a loop per image would cost more in
  // starting and joining threads than its work (a few stripes in all).
  if (tail == octaves) return;
  for (int o = tail; o < octaves; ++o)
    for (int i = 0; i < layers + 3; ++i) allocate(o, i);
  parallelFor("scale space", cv::Range(0, n), [&](const cv::Range& range) {
    StageTimer timer(kScaleSpace);
    for (int b = range.start; b < range.end; ++b)
      for (int o = tail; o < octaves; ++o)  // octave by octave: the scratch serves each in turn
        for (int i = 0; i < layers + 3; ++i) layerRows(b, o, i, 0, baseSize.height >> o);
  });
  for (int o = tail; o < octaves; ++o) dropTransients(o);
}

void buildScaleSpace(const cv::Mat& slice, int layers, double sigma, int octaves,
                     cv::Vec2d variance, cv::Vec2d targetVariance, bool detectionOnly,
                     ScaleSpace& space, BuildScratch* scratch, int firstOctave) {
  buildScaleSpaces({SliceBuild{&slice, variance, &space, scratch}}, layers, sigma, octaves,
                   firstOctave, targetVariance, detectionOnly);
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
