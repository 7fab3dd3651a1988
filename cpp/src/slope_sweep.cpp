#include "slope_sweep.hpp"
#include "hot_loop.hpp"
#include "profile.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace liff {
namespace detail {
namespace {

/// Half the side of the window costs are summed over (3 x 3): small, so that a window
/// on a thin occluder (a bar a few pixels wide) is mostly one layer.
constexpr int kWindowRadius = 1;
/// A pixel votes when its best slope costs less than this share of its mean cost: a
/// texture costs its contrast at wrong slopes and only noise at its own; a flat region
/// costs noise everywhere (ratio near 1); a window straddling an occlusion edge about
/// half its mean at either layer's slope.
constexpr float kConsistency = 0.4f;
/// ...and when its window's own texture (summed absolute differences of neighbouring
/// pixels) is this many times its best cost per view: otherwise the low best is that
/// of a flat window (whose mean cost is raised by structure that crosses it at other
/// slopes), not a match. Noise alone gives about 2 (two differences per pixel against
/// one per view); 3 keeps textures only a little above the noise of one view.
constexpr float kTextureToResidual = 3.f;
/// Scale (pixels of the swept light field) of the DoG that says whether LiFF could find
/// a feature at a voting pixel: the finest the sweep's resolution (usually half the
/// light field's) shows well.
constexpr double kDogSigma = 1.0;
/// Slopes are summed in this many chunks (merged in order after), whatever the number
/// of threads.
constexpr int kSweepChunks = 4;
/// Slopes whose costs are computed at once (one per task), each in its own buffers.
constexpr int kSweepSlopesPerGroup = 16;
/// Rows of the votes per task of folding a group's costs into them.
constexpr int kSweepRowsPerBand = 16;
/// A slope counts when its votes cover this share of the view's pixels (a 9 x 9 patch of
/// a 128 x 128 view): a layer large enough to hold features, not scattered edge votes...
constexpr double kMinVoteShare = 0.005;
/// ...or when votes where LiFF's detection threshold is reached gather in one place: a
/// small feature seen alike by the views, however small its share of a large view. Votes
/// are counted per cell of kVoteCell x kVoteCell pixels; a slope counts where, in a block
/// of 2 x 2 cells, it holds the most of its neighbouring slopes' votes and those three
/// slopes (1.5 pixels of parallax at the farthest view) hold at least kMinClusterVotes: a
/// 4 x 4 patch of the block's 16 x 16, which scattered edge and noise votes (a few per
/// slope in a whole view) do not reach...
constexpr int kVoteCell = 8;
constexpr int kMinClusterVotes = 16;
/// ...unless a slope within this many sweep slopes (one pixel of parallax at the farthest
/// view) counts by its share: such a cluster is that layer's votes spread over slopes.
constexpr int kClusterLayerGap = 2;
static_assert(kSweepRowsPerBand % kVoteCell == 0, "a band holds whole rows of cells");

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

// Per pixel of the reference view, over the slopes one chunk of the sweep covered: the
// least window cost and its slope index, and the sum and number of window costs.
struct Votes {
  cv::Mat best, index, sum, count;  // CV_32F, CV_32S, CV_32F, CV_32S
  /// Allocated, not yet set: clear() sets rows to no votes.
  explicit Votes(cv::Size size)
      : best(size, CV_32F), index(size, CV_32S), sum(size, CV_32F), count(size, CV_32S) {}
  /// Rows [rowBegin, rowEnd) to no votes: best +inf, index -1, sum and count 0.
  void clear(int rowBegin, int rowEnd) {
    const cv::Range rows(rowBegin, rowEnd);
    best.rowRange(rows).setTo(std::numeric_limits<float>::infinity());
    index.rowRange(rows).setTo(-1);
    sum.rowRange(rows).setTo(0);
    count.rowRange(rows).setTo(0);
  }
};

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

// The sweep over slopes m_k = (first + k) g, k < n: kSweepChunks chunks of slopes in
// parallel, each with its own votes, merged after in chunk order, so that the sums (and
// so the votes) are the same whatever the number of threads.
Votes sweepAll(const cv::Mat& reference, const std::vector<Compared>& views, long first, int n,
               double g) {
  const int chunks = std::max(1, std::min(n, kSweepChunks));
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
    const cv::Range rows(range.start * kSweepRowsPerBand,
                         std::min(reference.rows, range.end * kSweepRowsPerBand));
    for (int c = 1; c < chunks; ++c) {
      cv::Mat sum = all.sum.rowRange(rows), count = all.count.rowRange(rows);
      cv::Mat best = all.best.rowRange(rows), index = all.index.rowRange(rows);
      sum += partial[c].sum.rowRange(rows);
      count += partial[c].count.rowRange(rows);
      const cv::Mat better = partial[c].best.rowRange(rows) < best;
      partial[c].best.rowRange(rows).copyTo(best, better);
      partial[c].index.rowRange(rows).copyTo(index, better);
    }
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
  cv::GaussianBlur(reference, coarse, cv::Size(), kDogSigma * std::cbrt(2.0));
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
                        float featureResponse) {
  const std::vector<Compared> views = comparedViews(lf);
  if (views.empty() || !(lo <= hi)) return {};
  // Half a pixel of parallax at the farthest compared view between neighbouring slopes:
  // a fine texture half-way between whole-pixel slopes matches neither.
  int farthest = 0;
  for (const Compared& c : views) farthest = std::max(farthest, std::abs(c.offset));
  const double g = 0.5 / farthest;
  // One slope beyond each end, whose votes do not count: a layer beyond the range would
  // otherwise vote for the end slope, the best it is offered.
  const long first = long(std::ceil(lo / g - 1e-9)) - 1, last = long(std::floor(hi / g + 1e-9)) + 1;
  if (last - first < 2) return {};
  const int n = int(last - first + 1);
  const cv::Mat reference = viewValues(lf, lf.T / 2, lf.S / 2);
  const Votes all = sweepAll(reference, views, first, n, g);
  const cv::Mat texture = windowTexture(reference), response = windowResponse(reference);
  // Votes of the pixels that saw at least half the slopes (their best is a choice among
  // many), whose best is clearly better than their typical cost, whose window is
  // textured well above that best's residual, and where LiFF could find a feature;
  // counted per cell and slope, those where LiFF's detection threshold is reached also
  // apart (each band's rows of cells by one task: integers, the same in any order).
  const float compared = float(views.size());
  const int bands = (lf.V + kSweepRowsPerBand - 1) / kSweepRowsPerBand;
  const int cellsX = (lf.U + kVoteCell - 1) / kVoteCell, cellsY = (lf.V + kVoteCell - 1) / kVoteCell;
  const size_t cellSlopes = size_t(cellsX) * cellsY * n;  // [cell row][cell column][slope]
  std::vector<int> cellVotes(cellSlopes, 0), strongVotes(cellSlopes, 0);
  auto at = [&](std::vector<int>& counts, int y, int x) {
    return counts.data() + (size_t(y / kVoteCell) * cellsX + x / kVoteCell) * n;
  };
  parallelFor("survey plane sweep", cv::Range(0, bands), [&](const cv::Range& range) {
    for (int band = range.start; band < range.end; ++band)
      for (int y = band * kSweepRowsPerBand; y < std::min(lf.V, (band + 1) * kSweepRowsPerBand); ++y)
        for (int x = 0; x < lf.U; ++x) {
          const int count = all.count.at<int>(y, x);
          if (count < std::max(3, n / 2)) continue;
          const float best = all.best.at<float>(y, x), dog = response.at<float>(y, x);
          if (best < kConsistency * all.sum.at<float>(y, x) / count &&
              texture.at<float>(y, x) >= kTextureToResidual * best / compared &&
              dog >= minResponse) {
            const int k = all.index.at<int>(y, x);
            ++at(cellVotes, y, x)[k];
            if (dog >= featureResponse) ++at(strongVotes, y, x)[k];
          }
        }
  });
  std::vector<int> votes(n, 0);
  for (size_t c = 0; c < cellSlopes; c += n)
    for (int k = 0; k < n; ++k) votes[k] += cellVotes[c + k];
  // The slopes whose strong votes gather in a block of 2 x 2 cells (one cell where the
  // view has a single row or column of them).
  std::vector<char> clustered(n, 0);
  std::vector<int> block(n);
  for (int cy = 0; cy + 1 < std::max(2, cellsY); ++cy)
    for (int cx = 0; cx + 1 < std::max(2, cellsX); ++cx) {
      std::fill(block.begin(), block.end(), 0);
      for (int dy = 0; dy < std::min(2, cellsY); ++dy)
        for (int dx = 0; dx < std::min(2, cellsX); ++dx) {
          const int* counted = strongVotes.data() + (size_t(cy + dy) * cellsX + cx + dx) * n;
          for (int k = 0; k < n; ++k) block[k] += counted[k];
        }
      for (int k = 0; k < n; ++k) {
        const int below = k > 0 ? block[k - 1] : 0, above = k + 1 < n ? block[k + 1] : 0;
        if (block[k] >= below && block[k] >= above &&
            below + block[k] + above >= kMinClusterVotes)
          clustered[k] = 1;
      }
    }
  auto layer = [&](int k) { return k >= 0 && k < n && votes[k] >= kMinVoteShare * lf.V * lf.U; };
  auto counts = [&](int k) {
    if (layer(k)) return true;
    if (!clustered[k]) return false;
    for (int d = 1; d <= kClusterLayerGap; ++d)
      if (layer(k - d) || layer(k + d)) return false;  // that layer's own spread
    return true;
  };
  SweptSlopes found;
  found.beyondLow = counts(0);
  found.beyondHigh = counts(n - 1);
  // Each slope with enough votes stands for the slopes nearer to it than to its neighbours.
  for (int k = 1; k + 1 < n; ++k) {
    if (!counts(k)) continue;
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
