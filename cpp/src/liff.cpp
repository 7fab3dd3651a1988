// LiFF_Impl: parameters, persistence and the orchestration of
// light field -> focal slices -> scale spaces -> 4-D extrema -> descriptors.
#include <liff/liff.hpp>

#include "descriptor.hpp"
#include "extrema.hpp"
#include "focal_stack.hpp"
#include "light_field.hpp"
#include "memory.hpp"
#include "profile.hpp"
#include "scale_space.hpp"

#include <algorithm>
#include <cfloat>
#include <climits>
#include <tuple>
#include <cmath>
#include <map>
#include <memory>
#include <numeric>

namespace liff {

double keypointSlope(const cv::KeyPoint& keypoint) { return keypoint.class_id / kSlopeScale; }

int slopeToClassId(double slope) {
  const double scaled = std::round(slope * kSlopeScale);
  if (!(std::abs(scaled) <= double(INT_MAX)))
    CV_Error(cv::Error::StsOutOfRange,
             cv::format("LiFF: slope %g cannot be stored in class_id; expected |slope| < %g",
                        slope, INT_MAX / kSlopeScale));
  return int(scaled);
}

cv::String LiFF::getDefaultName() const { return "Feature2D.LiFF"; }

namespace {

using detail::LightField;
using detail::ScaleSpace;

void require(bool ok, const cv::String& message) {
  if (!ok) CV_Error(cv::Error::StsOutOfRange, "LiFF: " + message);
}

class LiFF_Impl : public LiFF {
 public:
  LiFF_Impl(int nfeatures, int nOctaveLayers, double contrastThreshold, double edgeThreshold,
            double sigma, double firstSlope, double lastSlope, int numSlopes, int descriptorType,
            bool rootSift) {
    setNFeatures(nfeatures);
    setNOctaveLayers(nOctaveLayers);
    setContrastThreshold(contrastThreshold);
    setEdgeThreshold(edgeThreshold);
    setSigma(sigma);
    setFirstSlope(firstSlope);
    setLastSlope(lastSlope);
    setNumSlopes(numSlopes);
    setDescriptorType(descriptorType);
    setRootSift(rootSift);
  }

  // --- parameters -------------------------------------------------------------
  void setNFeatures(int v) override {
    require(v >= 0, cv::format("nfeatures = %d; expected >= 0 (0 keeps all)", v));
    nfeatures_ = v;
  }
  int getNFeatures() const override { return nfeatures_; }
  void setNOctaveLayers(int v) override {
    require(v >= 1 && v <= 32, cv::format("nOctaveLayers = %d; expected in [1, 32]", v));
    nOctaveLayers_ = v;
  }
  int getNOctaveLayers() const override { return nOctaveLayers_; }
  void setContrastThreshold(double v) override {
    require(std::isfinite(v) && v >= 0,
            cv::format("contrastThreshold = %g; expected a finite value >= 0", v));
    contrastThreshold_ = v;
  }
  double getContrastThreshold() const override { return contrastThreshold_; }
  void setEdgeThreshold(double v) override {
    require(std::isfinite(v) && v >= 1,
            cv::format("edgeThreshold = %g; expected a finite value >= 1", v));
    edgeThreshold_ = v;
  }
  double getEdgeThreshold() const override { return edgeThreshold_; }
  void setSigma(double v) override {
    require(std::isfinite(v) && v >= 0.01 && v <= 100,
            cv::format("sigma = %g; expected a value in [0.01, 100]", v));
    sigma_ = v;
  }
  double getSigma() const override { return sigma_; }
  void setFirstSlope(double v) override {
    require(std::isfinite(v) && std::abs(v) <= kMaxAbsSlope,
            cv::format("firstSlope = %g; expected a finite value in [-%g, %g]", v, kMaxAbsSlope,
                       kMaxAbsSlope));
    firstSlope_ = v;
  }
  double getFirstSlope() const override { return firstSlope_; }
  void setLastSlope(double v) override {
    require(std::isfinite(v) && std::abs(v) <= kMaxAbsSlope,
            cv::format("lastSlope = %g; expected a finite value in [-%g, %g]", v, kMaxAbsSlope,
                       kMaxAbsSlope));
    lastSlope_ = v;
  }
  double getLastSlope() const override { return lastSlope_; }
  void setNumSlopes(int v) override {
    require(v >= 0 && v <= kMaxSlopes,
            cv::format("numSlopes = %d; expected in [0, %d] (0 = automatic)", v, kMaxSlopes));
    numSlopes_ = v;
  }
  int getNumSlopes() const override { return numSlopes_; }
  void setDescriptorType(int v) override {
    require(v == CV_32F || v == CV_8U,
            cv::format("descriptorType = %d; expected CV_32F (%d) or CV_8U (%d)", v, CV_32F,
                       CV_8U));
    descriptorType_ = v;
  }
  int getDescriptorType() const override { return descriptorType_; }
  void setRootSift(bool v) override { rootSift_ = v; }
  bool getRootSift() const override { return rootSift_; }
  void setMemoryLimitMB(double v) override {
    require(v >= 0, cv::format("memoryLimitMB = %g; expected >= 0 (0 = automatic, "
                               "infinity = no limit)", v));
    memoryLimitMB_ = v;
  }
  double getMemoryLimitMB() const override { return memoryLimitMB_; }

  std::vector<double> slopesFor(int T, int S) const override {
    require(T >= 1 && S >= 1,
            cv::format("T = %d, S = %d views; expected at least 1 view in each direction", T, S));
    require(firstSlope_ <= lastSlope_,
            cv::format("firstSlope = %g > lastSlope = %g; expected firstSlope <= lastSlope",
                       firstSlope_, lastSlope_));
    if (T == 1 && S == 1) return detail::slopeGrid(firstSlope_, lastSlope_, 1);
    int n = numSlopes_;
    if (n == 0) {
      n = std::max(T, S) | 1;  // smallest odd number >= max(T, S)
      require(n <= kMaxSlopes,
              cv::format("numSlopes = 0 (automatic) would use %d slopes for %d x %d views; "
                         "expected at most %d: check the axis order (T, S, V, U) or set "
                         "numSlopes", n, T, S, kMaxSlopes));
    }
    require(n == 1 || firstSlope_ < lastSlope_,
            cv::format("firstSlope = lastSlope = %g with numSlopes = %d; expected "
                       "firstSlope < lastSlope, or numSlopes = 1",
                       firstSlope_, n));
    return detail::slopeGrid(firstSlope_, lastSlope_, n);
  }

  // --- Feature2D ----------------------------------------------------------------
  int descriptorSize() const override { return detail::kDescriptorSize; }
  int descriptorType() const override { return descriptorType_; }
  int defaultNorm() const override { return cv::NORM_L2; }
  bool empty() const override { return false; }
  cv::String getDefaultName() const override { return LiFF::getDefaultName(); }

  void write(cv::FileStorage& fs) const override {
    writeFormat(fs);
    fs << "name" << getDefaultName();
    fs << "nfeatures" << nfeatures_ << "nOctaveLayers" << nOctaveLayers_;
    fs << "contrastThreshold" << contrastThreshold_ << "edgeThreshold" << edgeThreshold_;
    fs << "sigma" << sigma_ << "firstSlope" << firstSlope_ << "lastSlope" << lastSlope_;
    fs << "numSlopes" << numSlopes_ << "descriptorType" << descriptorType_;
    fs << "rootSift" << int(rootSift_);
  }

  void read(const cv::FileNode& node) override {
    // Algorithm::save() nests the parameters under the default name; accept both.
    cv::FileNode fn = node;
    if (fn.isMap() && !fn[getDefaultName()].empty()) fn = fn[getDefaultName()];
    if (!fn.isMap())
      CV_Error(cv::Error::StsBadArg, "LiFF: read() expected a map of parameters");
    if (!fn["name"].empty() && cv::String(fn["name"]) != getDefaultName())
      CV_Error(cv::Error::StsBadArg, "LiFF: read() found parameters of '" +
                                         cv::String(fn["name"]) + "'; expected '" +
                                         getDefaultName() + "'");
    // Validate everything on a copy before changing this object.
    LiFF_Impl next(*this);
    auto number = [&](const char* key) {
      const cv::FileNode n = fn[key];
      if (!n.isInt() && !n.isReal())
        CV_Error(cv::Error::StsBadArg,
                 cv::format("LiFF: read() found parameter '%s' of the wrong type; expected a "
                            "number", key));
      return n.isInt() ? double(int(n)) : double(n);
    };
    auto readInt = [&](const char* key, void (LiFF_Impl::*set)(int)) {
      if (fn[key].empty()) return;
      const double v = number(key);
      if (v != std::floor(v) || std::abs(v) > INT_MAX)
        CV_Error(cv::Error::StsBadArg,
                 cv::format("LiFF: read() found %s = %g; expected an integer", key, v));
      (next.*set)(int(v));
    };
    auto readReal = [&](const char* key, void (LiFF_Impl::*set)(double)) {
      if (!fn[key].empty()) (next.*set)(number(key));
    };
    readInt("nfeatures", &LiFF_Impl::setNFeatures);
    readInt("nOctaveLayers", &LiFF_Impl::setNOctaveLayers);
    readReal("contrastThreshold", &LiFF_Impl::setContrastThreshold);
    readReal("edgeThreshold", &LiFF_Impl::setEdgeThreshold);
    readReal("sigma", &LiFF_Impl::setSigma);
    readReal("firstSlope", &LiFF_Impl::setFirstSlope);
    readReal("lastSlope", &LiFF_Impl::setLastSlope);
    readInt("numSlopes", &LiFF_Impl::setNumSlopes);
    readInt("descriptorType", &LiFF_Impl::setDescriptorType);
    if (!fn["rootSift"].empty()) next.setRootSift(number("rootSift") != 0);
    *this = next;
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
  // Slopes beyond this many pixels per view step are surely a mistake.
  static constexpr double kMaxAbsSlope = 1e4;
  // More slopes than this is surely a mistake (each costs a full SIFT pass).
  static constexpr int kMaxSlopes = 4096;
  // compute() drops keypoints with |x|, |y| or size at least this (pixels).
  static constexpr float kMaxCoordinate = 1e6f;

  void describe(const std::vector<cv::KeyPoint>& keypoints, const std::vector<int>& sliceOf,
                const std::map<int, std::shared_ptr<ScaleSpace>>& window,
                cv::Mat& descriptors) const;

  int nfeatures_ = 0, nOctaveLayers_ = 3;
  double contrastThreshold_ = 0.04, edgeThreshold_ = 10, sigma_ = 1.6;
  double firstSlope_ = -1, lastSlope_ = 1;
  int numSlopes_ = 0, descriptorType_ = CV_32F;
  bool rootSift_ = false;
  double memoryLimitMB_ = 0;
};

// Index of the grid slope nearest to `slope` (the slice a keypoint is described on).
int nearestSlice(const std::vector<double>& slopes, double slope) {
  if (slopes.size() == 1) return 0;
  const double step = (slopes.back() - slopes.front()) / double(slopes.size() - 1);
  const long index = std::lround((slope - slopes.front()) / step);
  return int(std::min<long>(long(slopes.size()) - 1, std::max<long>(0, index)));
}

// Builds the scale spaces of the listed slices, at most `batch` at once (the memory
// estimate's count), their focal slices from `source`, reusing the pool's memory
// when given one (detection passes; `detectionOnly` pyramids).
void buildSlices(const LightField& lf, const std::vector<double>& slopes,
                 const std::vector<int>& which, int layers, double sigma, int octaves,
                 bool detectionOnly, int batch, detail::FocalSliceSource& source,
                 std::map<int, std::shared_ptr<ScaleSpace>>& window,
                 detail::ScaleSpacePool* pool = nullptr) {
  // Every slice is topped up to the largest interpolation blur of the grid.
  cv::Vec2d target(0, 0);
  for (double slope : slopes) {
    const cv::Vec2d v = detail::interpolationVariance(lf.T, lf.S, slope);
    target = cv::Vec2d(std::max(target[0], v[0]), std::max(target[1], v[1]));
  }
  const int n = int(which.size());
  source.prepare(which);
  std::vector<cv::Mat> slices;
  for (int k : which) slices.push_back(source.take(k));
  auto build = [&](int j, bool rowParallel) {
    detail::StageTimer timer(detail::kScaleSpace);
    std::unique_ptr<detail::BuildScratch> scratch = pool ? pool->takeScratch() : nullptr;
    std::shared_ptr<ScaleSpace> space = pool ? pool->takeSpace() : std::make_shared<ScaleSpace>();
    const cv::Vec2d variance = detail::interpolationVariance(lf.T, lf.S, slopes[which[j]]);
    detail::buildScaleSpace(slices[j], layers, sigma, octaves, variance, target, detectionOnly,
                            rowParallel, *space, scratch.get());
    slices[j].release();
    if (pool) pool->giveScratch(std::move(scratch));
    return space;
  };
  // Whole rounds of one slice per thread run in parallel (each slice serial inside);
  // the remainder is built one slice at a time with the parallelism inside it
  // (row-parallel blurs), so no thread idles.
  const int threads = std::max(1, std::min(cv::getNumThreads(), batch));
  const int parallelCount = threads > 1 ? n - n % threads : 0;
  std::vector<std::shared_ptr<ScaleSpace>> built(n);
  cv::parallel_for_(cv::Range(0, parallelCount), [&](const cv::Range& range) {
    for (int j = range.start; j < range.end; ++j) built[j] = build(j, false);
  }, threads);  // `threads` stripes: no more than that many built at once
  for (int j = parallelCount; j < n; ++j) built[j] = build(j, true);
  for (int j = 0; j < n; ++j) window[which[j]] = built[j];
}

// Rows of one octave image that one extrema-search task covers.
constexpr int kRowsPerSearchTask = 32;

constexpr double kBytesPerMB = 1024.0 * 1024.0;

// Slices searched together: one per thread, so that building their scale spaces
// keeps every thread busy; memory stays at (batch + 2) scale spaces. Results do
// not depend on it, so when memory is short the batch shrinks; when even one slice
// at a time does not fit, fail now, before the large allocations.
int sliceBatch(const LightField& lf, const detail::MemoryEstimate& need, double limitMB) {
  int batch = std::max(1, cv::getNumThreads());
  const bool automatic = limitMB == 0;
  const double limit = automatic ? detail::availableMemoryBytes() : limitMB * kBytesPerMB;
  if (limit <= 0 || std::isinf(limit)) return batch;  // unknown or unlimited
  while (batch > 1 && need.total(batch) > limit) --batch;
  if (need.total(batch) > limit)
    CV_Error(cv::Error::StsNoMem,
             cv::format("LiFF: a light field of %d x %d views of %d x %d pixels needs about "
                        "%.0f MB (grey light field %.0f MB, 3 scale spaces of %.0f MB, %.0f MB "
                        "while building one, %d focal slices of %.1f MB), more than the memory "
                        "limit of %.4g MB (%s); "
                        "expected a light field that fits: crop or downsample the views, or "
                        "raise the limit with setMemoryLimitMB",
                        lf.T, lf.S, lf.V, lf.U, need.total(1) / kBytesPerMB,
                        need.lightFieldBytes / kBytesPerMB, need.windowSliceBytes / kBytesPerMB,
                        need.buildBytes / kBytesPerMB, need.slicesAhead(1),
                        need.focalSliceBytes / kBytesPerMB, limit / kBytesPerMB,
                        automatic ? "automatic: the memory available now" : "setMemoryLimitMB"));
  return batch;
}

void LiFF_Impl::describe(const std::vector<cv::KeyPoint>& keypoints,
                         const std::vector<int>& sliceOf,
                         const std::map<int, std::shared_ptr<ScaleSpace>>& window,
                         cv::Mat& descriptors) const {
  cv::parallel_for_(cv::Range(0, int(keypoints.size())), [&](const cv::Range& range) {
    detail::StageTimer timer(detail::kDescriptors);
    float raw[detail::kDescriptorSize];
    for (int k = range.start; k < range.end; ++k) {
      const cv::KeyPoint& kp = keypoints[k];
      const ScaleSpace& space = *window.at(sliceOf[k]);
      int o = 0, layer = 0;
      CV_Assert(detail::unpackOctave(kp, space.octaves, space.layers, o, layer));
      const cv::Point2f pt(detail::viewToOctave(kp.pt.x, o), detail::viewToOctave(kp.pt.y, o));
      // Scale in octave pixels: size is a diameter in view pixels.
      const float scale = kp.size * 0.5f / std::ldexp(1.f, o + detail::kFirstOctave);
      // Descriptor rotation, reduced to [0, 360) whatever angle the keypoint carries
      // (cv2.KeyPoint's default is -1).
      float angle = std::fmod(360.f - kp.angle, 360.f);
      if (angle < 0.f) angle += 360.f;
      if (!(angle < 360.f) || std::abs(angle - 360.f) < FLT_EPSILON) angle = 0.f;
      detail::rawDescriptor(space.gaussian(o, layer), pt, angle, scale, raw);
      detail::finishDescriptor(raw, rootSift_, descriptors.row(k));
    }
  });
}

void LiFF_Impl::detectAndCompute(cv::InputArray image, cv::InputArray maskArray,
                                 std::vector<cv::KeyPoint>& keypoints,
                                 cv::OutputArray descriptorsOut, bool useProvidedKeypoints) {
  const cv::Mat input = image.getMat();
  LightField lf = detail::checkLightField(input);
  const cv::Mat mask = maskArray.getMat();
  detail::checkMask(mask, lf.viewSize());
  const std::vector<double> slopes = slopesFor(lf.T, lf.S);
  const int M = int(slopes.size());
  const double step = M > 1 ? (slopes.back() - slopes.front()) / (M - 1) : 0.0;
  const int octaves = detail::numOctaves(lf.viewSize());
  const bool wantDescriptors = descriptorsOut.needed();

  // Memory check before the grey conversion, the largest single allocation.
  detail::MemoryEstimate need = detail::sliceMemory(lf.viewSize(), nOctaveLayers_, octaves);
  need.lightFieldBytes = detail::conversionBytes(input, lf);
  const int batch = sliceBatch(lf, need, memoryLimitMB_);
  detail::convertLightField(input, lf);
  std::map<int, std::shared_ptr<ScaleSpace>> window;

  if (useProvidedKeypoints) {
    // Describe the given keypoints, each on the slice nearest its slope; drop those
    // whose packed octave/layer this light field's pyramid does not have.
    std::vector<cv::KeyPoint> kept;
    std::vector<int> sliceOf;
    for (const cv::KeyPoint& kp : keypoints) {
      int o, layer;
      // Coordinates and sizes beyond kMaxCoordinate cannot be described (and would
      // overflow the sampling window's integer arithmetic).
      const bool usable = std::abs(kp.pt.x) < kMaxCoordinate &&
                          std::abs(kp.pt.y) < kMaxCoordinate && kp.size > 0 &&
                          kp.size < kMaxCoordinate && std::isfinite(kp.angle);
      if (octaves < 1 || !usable || !detail::unpackOctave(kp, octaves, nOctaveLayers_, o, layer))
        continue;
      kept.push_back(kp);
      sliceOf.push_back(nearestSlice(slopes, keypointSlope(kp)));
    }
    keypoints = kept;
    if (!wantDescriptors) return;
    cv::Mat descriptors(int(kept.size()), detail::kDescriptorSize, descriptorType_);
    // Build each needed scale space once, `batch` slices at a time.
    detail::FocalSliceSource source(lf, slopes, 0);
    std::vector<int> needed(sliceOf);
    std::sort(needed.begin(), needed.end());
    needed.erase(std::unique(needed.begin(), needed.end()), needed.end());
    for (size_t first = 0; first < needed.size(); first += batch) {
      const std::vector<int> slices(needed.begin() + first,
                                    needed.begin() + std::min(needed.size(), first + batch));
      window.clear();
      buildSlices(lf, slopes, slices, nOctaveLayers_, sigma_, octaves, false, batch, source,
                  window);
      std::vector<cv::KeyPoint> group;
      std::vector<int> groupSlice, rows;
      for (size_t j = 0; j < kept.size(); ++j)
        if (window.count(sliceOf[j])) {
          group.push_back(kept[j]);
          groupSlice.push_back(sliceOf[j]);
          rows.push_back(int(j));
        }
      cv::Mat groupDescriptors(int(group.size()), detail::kDescriptorSize, descriptorType_);
      describe(group, groupSlice, window, groupDescriptors);
      for (size_t j = 0; j < rows.size(); ++j)
        groupDescriptors.row(int(j)).copyTo(descriptors.row(rows[j]));
    }
    descriptors.copyTo(descriptorsOut);
    return;
  }

  // Detection: a sliding window over the slope axis holds the scale spaces of the
  // slices being searched and their two neighbours; each batch of slices is built
  // and searched in parallel, and results are concatenated in slice order.
  keypoints.clear();
  std::vector<cv::Mat> descriptorBlocks;
  detail::ScaleSpacePool pool;
  detail::FocalSliceSource source(lf, slopes, need.slicesAhead(batch));
  const detail::DetectParams params{nOctaveLayers_, contrastThreshold_, edgeThreshold_, sigma_};
  for (int k0 = 0; octaves >= 1 && k0 < M; k0 += batch) {
    const int k1 = std::min(M, k0 + batch);  // search slices [k0, k1)
    std::vector<int> missing;
    for (int k = std::max(0, k0 - 1); k < std::min(M, k1 + 1); ++k)
      if (!window.count(k)) missing.push_back(k);
    buildSlices(lf, slopes, missing, nOctaveLayers_, sigma_, octaves, true, batch, source,
                window, &pool);

    // Search the batch as fixed row-stripe tasks over all its slices, octaves and
    // layers, so both cores stay busy; results are gathered in task order.
    struct Job {
      int slice;
      detail::SearchTask task;
    };
    std::vector<Job> jobs;
    for (int k = k0; k < k1; ++k)
      for (const detail::SearchTask& task : detail::searchTasks(*window.at(k), kRowsPerSearchTask))
        jobs.push_back({k, task});
    std::vector<std::vector<cv::KeyPoint>> found(jobs.size());
    cv::parallel_for_(cv::Range(0, int(jobs.size())), [&](const cv::Range& range) {
      for (int j = range.start; j < range.end; ++j) {
        const int k = jobs[j].slice;
        detail::SliceNeighbourhood slices;
        slices.here = window.at(k).get();
        slices.below = k > 0 ? window.at(k - 1).get() : nullptr;
        slices.above = k + 1 < M ? window.at(k + 1).get() : nullptr;
        slices.slope = slopes[k];
        slices.slopeStep = step;
        detail::StageTimer timer(detail::kExtrema);
        found[j] = detail::findKeypoints(slices, params, mask, jobs[j].task);
      }
    });
    const size_t first = keypoints.size();
    for (const std::vector<cv::KeyPoint>& part : found)
      keypoints.insert(keypoints.end(), part.begin(), part.end());
    if (wantDescriptors && keypoints.size() > first) {
      // Describe the whole batch in one parallel loop, each keypoint on the slice
      // nearest its slope (within one of its detection slice, so in the window).
      const std::vector<cv::KeyPoint> batchKeypoints(keypoints.begin() + first, keypoints.end());
      std::vector<int> sliceOf;
      for (const cv::KeyPoint& kp : batchKeypoints)
        sliceOf.push_back(nearestSlice(slopes, keypointSlope(kp)));
      cv::Mat block(int(batchKeypoints.size()), detail::kDescriptorSize, descriptorType_);
      describe(batchKeypoints, sliceOf, window, block);
      descriptorBlocks.push_back(block);
    }
    // Keep only slice k1 - 1, the lower neighbour of the next batch; the others'
    // memory goes to the next slices.
    for (auto it = window.begin(); it != window.end();) {
      if (it->first >= k1 - 1) {
        ++it;
        continue;
      }
      pool.giveSpace(std::move(it->second));
      it = window.erase(it);
    }
  }
  window.clear();

  cv::Mat descriptors;
  if (wantDescriptors) {
    descriptors.create(0, detail::kDescriptorSize, descriptorType_);
    for (const cv::Mat& block : descriptorBlocks)
      if (!block.empty()) descriptors.push_back(block);
  }

  // Sort by position, size, angle and slope (strongest first among equals) and drop
  // exact duplicates, which arise when two extrema refine to the same point; the
  // order then no longer depends on how the work was split.
  std::vector<int> order(keypoints.size());
  std::iota(order.begin(), order.end(), 0);
  auto key = [&](int i) {
    const cv::KeyPoint& k = keypoints[i];
    return std::make_tuple(k.pt.x, k.pt.y, k.size, k.angle, k.class_id, -k.response, k.octave);
  };
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return key(a) < key(b); });
  std::vector<int> unique;
  for (int i : order) {
    const cv::KeyPoint& k = keypoints[i];
    if (!unique.empty()) {
      const cv::KeyPoint& p = keypoints[unique.back()];
      if (p.pt == k.pt && p.size == k.size && p.angle == k.angle && p.class_id == k.class_id)
        continue;
    }
    unique.push_back(i);
  }
  // nfeatures: keep the strongest responses (ties broken by the order above).
  if (nfeatures_ > 0 && int(unique.size()) > nfeatures_) {
    std::vector<int> byResponse = unique;
    std::stable_sort(byResponse.begin(), byResponse.end(), [&](int a, int b) {
      return keypoints[a].response > keypoints[b].response;
    });
    byResponse.resize(nfeatures_);
    std::vector<bool> keep(keypoints.size(), false);
    for (int i : byResponse) keep[i] = true;
    std::vector<int> kept;
    for (int i : unique)
      if (keep[i]) kept.push_back(i);
    unique.swap(kept);
  }
  std::vector<cv::KeyPoint> result;
  result.reserve(unique.size());
  for (int i : unique) result.push_back(keypoints[i]);
  keypoints.swap(result);
  if (wantDescriptors) {
    cv::Mat out(int(unique.size()), detail::kDescriptorSize, descriptorType_);
    for (size_t j = 0; j < unique.size(); ++j) descriptors.row(unique[j]).copyTo(out.row(int(j)));
    out.copyTo(descriptorsOut);
  }
}

}  // namespace

cv::Ptr<LiFF> LiFF::create(int nfeatures, int nOctaveLayers, double contrastThreshold,
                           double edgeThreshold, double sigma, double firstSlope, double lastSlope,
                           int numSlopes, int descriptorType, bool rootSift) {
  return cv::makePtr<LiFF_Impl>(nfeatures, nOctaveLayers, contrastThreshold, edgeThreshold, sigma,
                                firstSlope, lastSlope, numSlopes, descriptorType, rootSift);
}

}  // namespace liff
