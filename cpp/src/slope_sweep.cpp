#include "slope_sweep.hpp"
#include "hot_loop.hpp"
#include "profile.hpp"
#include "slope_range.hpp"
#include "sweep_votes.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace liff {
namespace detail {
namespace {

/// Half the side of the window costs are summed over (3 x 3): small, so that a window
/// on a thin occluder (a bar a few pixels wide) is mostly one layer.
constexpr int kWindowRadius = 1;
/// Scale (pixels of the swept light field) of the DoG that says whether LiFF could find
/// a feature at a voting pixel: the finest the sweep's resolution (usually half the
/// light field's) shows well.
constexpr double kDogSigma = 1.0;
/// Layers per octave of that DoG (its two scales 2^(1/3) apart, as LiFF's default).
constexpr int kDogLayers = 3;
/// Slopes are summed in this many chunks (merged in order after), whatever the number
/// of threads.
constexpr int kSweepChunks = 4;
/// Slopes whose costs are computed at once (one per task), each in its own buffers.
constexpr int kSweepSlopesPerGroup = 16;
/// Rows of the votes per task of folding a group's costs into them.
constexpr int kSweepRowsPerBand = 16;

// The view's values, with NaN where its weight (alpha) is under half the largest, so
// that no window touching an invalid sample votes.
cv::Mat viewValues(const LightField& lf, int t, int s) {
  const cv::Mat values = lf.viewMat(t, s);
  if (lf.weights.empty()) return values;
  const cv::Mat& weights = lf.weights[size_t(t) * lf.S + s];
  cv::Mat out(values.size(), CV_32F);
  const float floor = 0.5f * lf.maxWeight;
  for (int y = 0; y < lf.V; ++y)
    for (int x = 0; x < lf.U; ++x) {
      const float w = weights.at<float>(y, x);
      out.at<float>(y, x) = w > floor ? values.at<float>(y, x) / w
                                      : std::numeric_limits<float>::quiet_NaN();
    }
  return out;
}

// A view at `offset` view steps from the reference view along one axis (x for a view of
// the reference's row, y for one of its column).
// Buffers one chunk of the sweep reuses from slope to slope.
struct Scratch {
  cv::Mat cost, boxed;
};

struct Compared {
  cv::Mat values;
  int offset;
  bool alongX;
};

// Where the compared view shows the reference's pixel x at slope m: x - m * offset =
// x - i - f (i whole, f in [0, 1)), interpolated between samples x - i and x - i - 1.
struct Sampling {
  int i;
  float f;
};
Sampling sampling(const Compared& c, double m) {
  const double p = m * c.offset;
  const int i = int(std::floor(p));
  return {i, float(p - i)};
}

// out[x] += |view[x] - ref[x]|: a compared view's residual where it samples whole pixels.
// The first view's (`first`) starts the sum from 0 without reading `out` (0 + r is r).
LIFF_HOT_LOOP void addResidualRow(const float* view, const float* ref, int width, bool first,
                                  float* out) {
  if (first)
    for (int x = 0; x < width; ++x) out[x] = std::abs(view[x] - ref[x]);
  else
    for (int x = 0; x < width; ++x) out[x] += std::abs(view[x] - ref[x]);
}

// out[x] += |w0 (view - ref)[x] + w1 (viewFar - refFar)[x]|: its residual between the
// near and the far samples (`first` as above).
LIFF_HOT_LOOP void addInterpolatedResidualRow(const float* view, const float* ref,
                                              const float* viewFar, const float* refFar,
                                              float w0, float w1, int width, bool first,
                                              float* out) {
  if (first)
    for (int x = 0; x < width; ++x)
      out[x] = std::abs(w0 * (view[x] - ref[x]) + w1 * (viewFar[x] - refFar[x]));
  else
    for (int x = 0; x < width; ++x)
      out[x] += std::abs(w0 * (view[x] - ref[x]) + w1 * (viewFar[x] - refFar[x]));
}

// Folds one row of slope k's window costs c into the votes' row, columns [begin, end).
// Branch-free, so that it vectorises; a NaN (an invalid sample in the window) counts
// for nothing.
LIFF_HOT_LOOP void foldRow(const float* c, int k, int begin, int end, float* best, int* index,
                           float* sum, int* count) {
  for (int x = begin; x < end; ++x) {
    const bool valid = c[x] == c[x], better = c[x] < best[x];
    sum[x] += valid ? c[x] : 0.f;
    count[x] += valid ? 1 : 0;
    best[x] = better ? c[x] : best[x];
    index[x] = better ? k : index[x];
  }
}

// One slope of the sweep: cost(x, y) = sum over the compared views of
// |L_view(x - m d) - L_ref(x - f)| (d the view's offset from the reference along its
// axis, f the fractional part of m d): the reference is interpolated as the view is, so
// that the residual at the right slope is noise, not the blur of interpolating one side
// only; summed over the window, where every view sees the pixel (then folded into the
// votes, foldVotes). Into `scratch.boxed`, over `roi`, the region every compared view
// sees; false when that region is smaller than a window.
bool slopeCost(const cv::Mat& reference, const std::vector<Compared>& views, double m,
               Scratch& scratch, cv::Rect& roi) {
  int x0 = 0, x1 = reference.cols, y0 = 0, y1 = reference.rows;
  for (const Compared& c : views) {
    const Sampling at = sampling(c, m);
    int& lower = c.alongX ? x0 : y0;
    int& upper = c.alongX ? x1 : y1;
    // Samples x - i - 1 (and x - 1 of the reference) need x >= i + 1 (and x >= 1).
    lower = std::max(lower, std::max(at.i, 0) + (at.f > 0 ? 1 : 0));
    upper = std::min(upper, (c.alongX ? reference.cols : reference.rows) + std::min(at.i, 0));
  }
  const int window = 2 * kWindowRadius + 1;
  if (x1 - x0 < window || y1 - y0 < window) return false;
  roi = cv::Rect(x0, y0, x1 - x0, y1 - y0);
  // One pass per row and view: |(1 - f) (L_v - L_ref)(near) + f (L_v - L_ref)(far)|, the
  // far samples one pixel further along the view's axis.
  scratch.cost.create(reference.size(), CV_32F);  // kept from slope to slope
  scratch.boxed.create(reference.size(), CV_32F);
  cv::Mat cost = scratch.cost(cv::Rect(cv::Point(0, 0), roi.size()));
  cv::Mat boxed = scratch.boxed(cv::Rect(cv::Point(0, 0), roi.size()));
  for (const Compared& c : views) {
    const bool first = &c == &views.front();  // its residuals start each pixel's sum
    const Sampling at = sampling(c, m);
    const float w0 = 1 - at.f, w1 = at.f;
    for (int y = 0; y < roi.height; ++y) {
      float* out = cost.ptr<float>(y);
      const int row = roi.y + y;
      const float* view = c.values.ptr<float>(c.alongX ? row : row - at.i) + roi.x - (c.alongX ? at.i : 0);
      const float* ref = reference.ptr<float>(row) + roi.x;
      if (at.f == 0) {
        addResidualRow(view, ref, roi.width, first, out);
        continue;
      }
      // The far samples: the previous pixel of the row, or the previous row.
      const float* viewFar = c.alongX ? view - 1 : c.values.ptr<float>(row - at.i - 1) + roi.x;
      const float* refFar = c.alongX ? ref - 1 : reference.ptr<float>(row - 1) + roi.x;
      addInterpolatedResidualRow(view, ref, viewFar, refFar, w0, w1, roi.width, first, out);
    }
  }
  // (Its sums run left to right and top to bottom: a pixel's value depends on the
  // pixels before it only, so the region's far edges, which read past it, are never
  // used below.)
  cv::boxFilter(cost, boxed, -1, cv::Size(window, window), cv::Point(-1, -1), false);
  return true;
}

// Folds slope k's box-filtered cost (`boxed` over `roi`) into `votes` on the votes'
// rows [rowBegin, rowEnd), only where the whole window lies inside the region every
// view sees.
void foldVotes(const cv::Mat& boxed, const cv::Rect& roi, int k, Votes& votes, int rowBegin,
               int rowEnd) {
  const int x0 = roi.x, y0 = roi.y;
  const int yBegin = std::max(kWindowRadius, rowBegin - y0);
  const int yEnd = std::min(roi.height - kWindowRadius, rowEnd - y0);
  for (int y = yBegin; y < yEnd; ++y) {
    const float* c = boxed.ptr<float>(y);
    float* best = votes.best.ptr<float>(y + y0) + x0;
    int* index = votes.index.ptr<int>(y + y0) + x0;
    float* sum = votes.sum.ptr<float>(y + y0) + x0;
    int* count = votes.count.ptr<int>(y + y0) + x0;
    foldRow(c, k, kWindowRadius, roi.width - kWindowRadius, best, index, sum, count);
  }
}

// Whether view (t, s) is mostly valid: its mean weight (alpha) at least half the largest.
bool usable(const LightField& lf, int t, int s) {
  if (lf.weights.empty()) return true;
  const cv::Mat& weights = lf.weights[size_t(t) * lf.S + s];
  return cv::mean(weights)[0] >= 0.5 * lf.maxWeight;
}

// The views compared with the reference (T / 2, S / 2): along its row and its column, on
// each side the outermost usable view (the outer views of a lenslet capture may be dark).
std::vector<Compared> comparedViews(const LightField& lf) {
  const int rt = lf.T / 2, rs = lf.S / 2;
  std::vector<Compared> views;
  if (!usable(lf, rt, rs)) return views;
  // From an end of the row (alongX) or column towards the reference, the first usable view.
  auto outermost = [&](int end, int step, bool alongX) {
    const int reference = alongX ? rs : rt;
    for (int i = end; i != reference; i += step) {
      const int t = alongX ? rt : i, s = alongX ? i : rs;
      if (usable(lf, t, s)) {
        views.push_back({viewValues(lf, t, s), i - reference, alongX});
        return;
      }
    }
  };
  outermost(0, 1, true);
  outermost(lf.S - 1, -1, true);
  outermost(0, 1, false);
  outermost(lf.T - 1, -1, false);
  return views;
}

// The sweep over slopes m_k = (first + k) g, k < n: `chunkCount` chunks of slopes in
// parallel, each with its own votes, merged after in chunk order, so that the sums (and
// so the votes) are the same whatever the number of threads (a few slopes: one chunk).
Votes sweepAll(const cv::Mat& reference, const std::vector<Compared>& views, long first, int n,
               double g, int chunkCount = kSweepChunks) {
  const int chunks = std::max(1, std::min(n, chunkCount));
  std::vector<Votes> partial;
  for (int c = 0; c < chunks; ++c) partial.emplace_back(reference.size());
  const int bands = (reference.rows + kSweepRowsPerBand - 1) / kSweepRowsPerBand;
  parallelFor("survey plane sweep", cv::Range(0, bands), [&](const cv::Range& range) {
    for (Votes& votes : partial)
      votes.clear(range.start * kSweepRowsPerBand,
                  std::min(reference.rows, range.end * kSweepRowsPerBand));
  });
  std::vector<int> chunkOf(n);  // chunk c holds slopes [c n / chunks, (c + 1) n / chunks)
  for (int c = 0; c < chunks; ++c)
    for (int k = c * n / chunks; k < (c + 1) * n / chunks; ++k) chunkOf[k] = c;
  // Slopes in groups: each group's costs in parallel, one slope a task in its own
  // buffers, then folded into their chunk's votes in slope order, in parallel over row
  // bands: every pixel's sums run as one chunk's loop over its slopes would, so the
  // votes are the same, and all threads have work whatever the number of chunks.
  std::vector<Scratch> scratch(std::min(n, kSweepSlopesPerGroup));
  std::vector<cv::Rect> roi(scratch.size());
  std::vector<char> swept(scratch.size());
  for (int g0 = 0; g0 < n; g0 += int(scratch.size())) {
    const int g1 = std::min(n, g0 + int(scratch.size()));
    parallelFor("survey plane sweep", cv::Range(g0, g1), [&](const cv::Range& range) {
      for (int k = range.start; k < range.end; ++k)
        swept[k - g0] = slopeCost(reference, views, double(first + k) * g, scratch[k - g0],
                                  roi[k - g0]);
    });
    parallelFor("survey plane sweep", cv::Range(0, bands), [&](const cv::Range& range) {
      for (int band = range.start; band < range.end; ++band) {
        const int r0 = band * kSweepRowsPerBand;
        const int r1 = std::min(reference.rows, r0 + kSweepRowsPerBand);
        for (int k = g0; k < g1; ++k)
          if (swept[k - g0])
            foldVotes(scratch[k - g0].boxed, roi[k - g0], k, partial[chunkOf[k]], r0, r1);
      }
    });
  }
  // Merged in chunk order, band by band (each pixel's sums in the same order).
  Votes& all = partial[0];
  parallelFor("survey plane sweep", cv::Range(0, bands), [&](const cv::Range& range) {
    const int r0 = range.start * kSweepRowsPerBand;
    const int r1 = std::min(reference.rows, range.end * kSweepRowsPerBand);
    for (int c = 1; c < chunks; ++c) all.merge(partial[c], 0, r0, r1);
  });
  return all;
}

// Per pixel, the texture of its window: the sum of |dL/dx| + |dL/dy| (forward differences).
cv::Mat windowTexture(const cv::Mat& reference) {
  const int U = reference.cols, V = reference.rows;
  cv::Mat dx(reference.size(), CV_32F, cv::Scalar(0)), dy(reference.size(), CV_32F, cv::Scalar(0));
  cv::absdiff(reference.colRange(1, U), reference.colRange(0, U - 1), dx.colRange(0, U - 1));
  cv::absdiff(reference.rowRange(1, V), reference.rowRange(0, V - 1), dy.rowRange(0, V - 1));
  cv::Mat texture = dx + dy;
  const int window = 2 * kWindowRadius + 1;
  cv::boxFilter(texture, texture, -1, cv::Size(window, window), cv::Point(-1, -1), false);
  return texture;
}

// Per pixel, what LiFF's detection could see there: the largest |DoG| within its window
// at the finest scale the sweep's resolution shows (sigma kDogSigma and 2^(1/3) kDogSigma,
// neighbouring layers of LiFF's scale space).
cv::Mat windowResponse(const cv::Mat& reference) {
  cv::Mat fine, coarse, response;
  cv::GaussianBlur(reference, fine, cv::Size(), kDogSigma);
  cv::GaussianBlur(reference, coarse, cv::Size(), kDogSigma * std::cbrt(2.0));  // kDogLayers
  response = cv::abs(coarse - fine);
  const int window = 2 * kWindowRadius + 1;
  cv::dilate(response, response, cv::Mat::ones(window, window, CV_8U));
  return response;
}

}  // namespace

std::vector<bool> sweptViews(int T, int S) {
  std::vector<bool> swept(size_t(T) * S, false);
  for (int t = 0; t < T; ++t) swept[size_t(t) * S + S / 2] = true;
  for (int s = 0; s < S; ++s) swept[size_t(T / 2) * S + s] = true;
  return swept;
}

SweptSlopes sweepSlopes(const LightField& lf, double lo, double hi, float minResponse,
                        float featureResponse, double beyondLow, double beyondHigh) {
  const std::vector<Compared> views = comparedViews(lf);
  if (views.empty() || !(lo <= hi)) return {};
  // Half a pixel of parallax at the farthest compared view between neighbouring slopes:
  // a fine texture half-way between whole-pixel slopes matches neither.
  int farthest = 0;
  for (const Compared& c : views) farthest = std::max(farthest, std::abs(c.offset));
  const double g = 0.5 / farthest;
  // One slope beyond each end, whose votes do not count: a layer beyond the range would
  // otherwise vote for the end slope, the best it is offered.
  const long firstIn = long(std::ceil(lo / g - 1e-9)), lastIn = long(std::floor(hi / g + 1e-9));
  if (lastIn < firstIn) return {};
  const long first = firstIn - 1, last = lastIn + 1;
  const int n = int(last - first + 1);
  const cv::Mat reference = viewValues(lf, lf.T / 2, lf.S / 2);
  const Votes inRange = sweepAll(reference, views, first, n, g);
  const cv::Mat texture = windowTexture(reference), response = windowResponse(reference);
  // Votes of the pixels that saw at least half the slopes (their best is a choice among
  // many): sweep_votes.hpp.
  const int minCount = std::max(3, n / 2);
  const VoteCounts counts = countVotes(inRange, n, texture, response, int(views.size()),
                                       minCount, minResponse, featureResponse);
  const Clusters clusters = findClusters(counts);
  // Whether the views of the reference's row and column agree at a point at slope
  // (origin + k) g (seenCoherence, as the survey's features' test), or within a sweep slope of
  // it in half steps: a vote's slope is that of its window, and the strongest vote of a
  // small feature lies on its edge, where a quarter pixel of parallax already matters; a
  // repeated pattern's alias is a whole period off at the outermost views.
  // At least half the views of the row and column must see the point and agree: near a
  // border, at a large slope, the few that still see it may be those a repeated pattern
  // matches (every other one at half its period).
  const std::vector<bool> rowAndColumn = sweptViews(lf.T, lf.S);
  int rowAndColumnViews = 0;
  for (bool swept : rowAndColumn) rowAndColumnViews += swept;
  auto agreement = [&](long origin) -> Agreement {
    return [&, origin](cv::Point point, int k) {
      const cv::KeyPoint at(cv::Point2f(point), float(2 * kDogSigma));
      for (int half = -2; half <= 2; ++half) {
        const double m = (double(origin + k) + 0.5 * half) * g;
        int used = 0;
        const double kappa = seenCoherence(lf, at, m, kDogLayers, &rowAndColumn, used);
        if (2 * used >= rowAndColumnViews && used >= 2 && kappa >= minCoherence(used))
          return true;
      }
      return false;
    };
  };
  SweptSlopes found;
  // Beyond each end: the slope next to it, or as far as asked, swept apart and merged
  // with the range's votes (which stay as they were), so that a pixel votes beyond only
  // where it matches better there than anywhere in the range.
  const long below = std::max(1L, long(std::ceil(beyondLow / g - 1e-9)));
  const long above = std::max(1L, long(std::ceil(beyondHigh / g - 1e-9)));
  if (below == 1 && above == 1) {
    found.beyondLow = structureAt(counts, clusters, 0, agreement(first));
    found.beyondHigh = structureAt(counts, clusters, n - 1, agreement(first));
  } else {
    const long wideFirst = firstIn - below, wideLast = lastIn + above;
    const int wideN = int(wideLast - wideFirst + 1);
    std::unique_ptr<Votes> lowPart, highPart;
    if (first > wideFirst)
      lowPart = std::make_unique<Votes>(
          sweepAll(reference, views, wideFirst, int(first - wideFirst), g, 1));
    if (wideLast > last)
      highPart = std::make_unique<Votes>(
          sweepAll(reference, views, last + 1, int(wideLast - last), g, 1));
    Votes wide(reference.size());
    const int bands = (reference.rows + kSweepRowsPerBand - 1) / kSweepRowsPerBand;
    parallelFor("survey plane sweep", cv::Range(0, bands), [&](const cv::Range& range) {
      const int r0 = range.start * kSweepRowsPerBand;
      const int r1 = std::min(reference.rows, range.end * kSweepRowsPerBand);
      wide.clear(r0, r1);
      if (lowPart) wide.merge(*lowPart, 0, r0, r1);
      wide.merge(inRange, int(first - wideFirst), r0, r1);
      if (highPart) wide.merge(*highPart, int(last + 1 - wideFirst), r0, r1);
    });
    // Only the slopes beyond the range, and the range's end slopes beside them (a cluster
    // there is the end's, not beyond), are counted and searched for clusters.
    const int kFirst = int(firstIn - wideFirst), kLast = int(lastIn - wideFirst);
    const VoteCounts wideCounts =
        countVotes(wide, wideN, texture, response, int(views.size()), minCount, minResponse,
                   featureResponse, cv::Range(kFirst + 1, std::max(kFirst + 1, kLast)));
    std::vector<char> beyond(wideN, 0);
    for (int k = 0; k < wideN; ++k) beyond[k] = k < kFirst || k > kLast;
    const Clusters wideClusters = findClusters(wideCounts, &beyond);
    const Agreement wideAgreement = agreement(wideFirst);
    for (int k = 0; k < kFirst && !found.beyondLow; ++k)
      found.beyondLow = structureAt(wideCounts, wideClusters, k, wideAgreement);
    for (int k = wideN - 1; k > kLast && !found.beyondHigh; --k)
      found.beyondHigh = structureAt(wideCounts, wideClusters, k, wideAgreement);
  }
  // Each slope with enough votes stands for the slopes nearer to it than to its neighbours.
  const Agreement inRangeAgreement = agreement(first);
  for (int k = 1; k + 1 < n; ++k) {
    if (!slopeCounts(counts, clusters, k, inRangeAgreement)) continue;
    const double m = double(first + k) * g;
    SlopeIntervals& intervals = found.intervals;
    if (!intervals.empty() && intervals.back().second >= m - 0.5 * g - 1e-9)
      intervals.back().second = m + 0.5 * g;
    else
      intervals.emplace_back(m - 0.5 * g, m + 0.5 * g);
  }
  return found;
}

}  // namespace detail
}  // namespace liff
