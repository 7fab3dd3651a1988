#include "focal_stack.hpp"

#include "hot_loop.hpp"
#include "vec8.hpp"
#include "profile.hpp"

#include <algorithm>
#include <cmath>

namespace liff {
namespace detail {
namespace {

// Rows of the slice one parallel task renders: as many as give each thread
// kTasksPerThread tasks, within [kMinRowsPerTask, kMaxRowsPerTask]. A task reads the
// source rows its rows need plus the spread of the views' shifts, so longer tasks read
// the light field fewer times (-8% on a one-thread pass); every output row sums the
// same terms in the same order whatever the split, so results never depend on it.
constexpr int kMinRowsPerTask = 8, kMaxRowsPerTask = 32, kTasksPerThread = 4;

int rowsPerTask(int V) {
  const int threads = std::max(1, plannedThreads());
  return std::min(kMaxRowsPerTask, std::max(kMinRowsPerTask, V / (kTasksPerThread * threads)));
}

// A pixel whose summed tap weight is at most this (relative to one full-weight sample)
// has no valid sample: it is set to 0 rather than divided by almost nothing.
constexpr float kNoSampleWeight = 1e-6f;

// Largest shift we represent (light field sides are at most 2^20).
constexpr double kMaxShift = double(1 << 22);

// Integer and fractional parts of a view's shift: sample x + shift = x + whole + frac.
struct Shift {
  int whole;
  float frac;  // in [0, 1)
  explicit Shift(double shift) {
    // A view shifted beyond any view size contributes nothing; clamping keeps the
    // integer arithmetic below far from overflow.
    shift = std::min(kMaxShift, std::max(-kMaxShift, shift));
    const double w = std::floor(shift);
    whole = int(w);
    frac = float(shift - w);
  }
};

// Columns [begin, end) where both bilinear taps of every view fall inside its row:
// 0 <= x + whole_s and x + whole_s + 1 <= U - 1 for every view s.
struct Interior {
  int begin, end;
  Interior(const std::vector<Shift>& shifts, int U) : begin(0), end(U) {
    for (const Shift& shift : shifts) {
      begin = std::max(begin, -shift.whole);
      end = std::min(end, U - 1 - shift.whole);
    }
    begin = std::min(begin, U);
    end = std::max(begin, end);
  }
};

// One row of H, the sum over a view row's S views of each view's row sampled at
// x + shift_s with the bilinear weights (1 - frac_s, frac_s):
//   out[x] = sum_s ((1 - f_s) src_s[x + whole_s] + f_s src_s[x + whole_s + 1]),
// added in view order from 0, taps outside the row skipped (each added on its own).
// Across `interior` no tap is skipped, and each vector of columns keeps its sum in a
// register over the views: a view costs two loads and no store. Every column adds the
// same terms in the same order whichever path it takes.
LIFF_HOT_LOOP void sumShiftedRows(const float* const* src, const Shift* shift, int S, int U,
                                  Interior interior, float* out) {
  auto column = [&](int x) {
    float sum = 0.f;
    for (int s = 0; s < S; ++s) {
      const float w0 = 1.f - shift[s].frac, w1 = shift[s].frac;
      const int x0 = x + shift[s].whole, x1 = x0 + 1;
      if (x0 >= 0 && x1 < U) {
        sum += w0 * src[s][x0] + w1 * src[s][x1];
      } else {
        if (x0 >= 0 && x0 < U) sum += w0 * src[s][x0];
        if (x1 >= 0 && x1 < U) sum += w1 * src[s][x1];
      }
    }
    return sum;
  };
  int x = 0;
#ifdef LIFF_VEC8
  // A vector of columns [x, x + 8) near the borders: views whose taps all fall inside
  // take the vector form, the others each column's own (the same terms as column()).
  auto edgeVector = [&](int x) {
    Vec8 acc = {};
    for (int s = 0; s < S; ++s) {
      const float w0 = 1.f - shift[s].frac, w1 = shift[s].frac;
      const int x0 = x + shift[s].whole;
      if (x0 >= 0 && x0 + kLanes < U) {
        acc += w0 * load(src[s] + x0) + w1 * load(src[s] + x0 + 1);
        continue;
      }
      for (int i = 0; i < kLanes; ++i) {
        const int c0 = x0 + i, c1 = c0 + 1;
        if (c0 >= 0 && c1 < U) {
          acc[i] += w0 * src[s][c0] + w1 * src[s][c1];
        } else {
          if (c0 >= 0 && c0 < U) acc[i] += w0 * src[s][c0];
          if (c1 >= 0 && c1 < U) acc[i] += w1 * src[s][c1];
        }
      }
    }
    store(out + x, acc);
  };
  for (; x < interior.begin && x + kLanes <= U; x += kLanes) edgeVector(x);
#endif
  for (; x < interior.begin; ++x) out[x] = column(x);
#ifdef LIFF_VEC8
  // 4 vectors per step: the adds of one vector form a chain over the views. A view
  // shifted by whole pixels (frac 0: the centre view, and the outermost ones at every
  // slope of the default grid) adds its sample alone: 1 * a + 0 * b is a, exactly.
  constexpr int kVectors = 4, kStep = kVectors * kLanes;
  for (; x + kStep <= interior.end; x += kStep) {
    Vec8 acc[kVectors] = {};
    for (int s = 0; s < S; ++s) {
      const float w0 = 1.f - shift[s].frac, w1 = shift[s].frac;
      const float* p = src[s] + x + shift[s].whole;
      if (w1 == 0.f)
        for (int v = 0; v < kVectors; ++v) acc[v] += load(p + v * kLanes);
      else
        for (int v = 0; v < kVectors; ++v)
          acc[v] += w0 * load(p + v * kLanes) + w1 * load(p + v * kLanes + 1);
    }
    for (int v = 0; v < kVectors; ++v) store(out + x + v * kLanes, acc[v]);
  }
  for (; x + kLanes <= interior.end; x += kLanes) {
    Vec8 acc = {};
    for (int s = 0; s < S; ++s) {
      const float* p = src[s] + x + shift[s].whole;
      if (shift[s].frac == 0.f)
        acc += load(p);
      else
        acc += (1.f - shift[s].frac) * load(p) + shift[s].frac * load(p + 1);
    }
    store(out + x, acc);
  }
  for (; x + kLanes <= U; x += kLanes) edgeVector(x);
#endif
  for (; x < U; ++x) out[x] = column(x);
}

// sum[x] += weight * row[x]: the vertical taps.
LIFF_HOT_LOOP void addScaled(const float* row, float weight, int U, float* sum) {
  for (int x = 0; x < U; ++x) sum[x] += weight * row[x];
}

// Total bilinear weight that falls inside [0, n) at each position p, over all shifts:
// the per-axis factor of the normalisation (the weights are separable in x and y).
std::vector<float> insideWeight(const std::vector<Shift>& shifts, int n) {
  std::vector<float> weight(n, 0.f);
  for (const Shift& shift : shifts)
    for (int p = 0; p < n; ++p) {
      const int p0 = p + shift.whole;
      if (p0 >= 0 && p0 < n) weight[p] += 1.f - shift.frac;
      if (p0 + 1 >= 0 && p0 + 1 < n) weight[p] += shift.frac;
    }
  return weight;
}

}  // namespace

cv::Vec2d interpolationVariance(int T, int S, double slope) {
  auto meanVariance = [slope](int n) {
    double sum = 0;
    for (int i = 0; i < n; ++i) {
      const double f = Shift(-slope * (i - 0.5 * (n - 1))).frac;
      sum += f * (1 - f);
    }
    return sum / n;
  };
  return cv::Vec2d(meanVariance(S), meanVariance(T));
}

namespace {

// The view shifts and (without alpha) the separable normalisation of one slope.
struct SlopeShifts {
  std::vector<Shift> x, y;  // per view column s and row t
  Interior interior{{}, 0};  // columns where no view's x taps leave it
  std::vector<float> wx, wy;  // inside weight per column and row (no alpha only)
};

// One parallel task of the separable shift-and-sum, for every slope at once: output
// rows [yBegin, yEnd) of
//   out_k(x, y) = sum_t sum_j wy_tj * H_kt(y + whole_t + j, x),
//   H_kt(r, x) = sum_s sum_i wx_si * D(t, s, r, x + whole_s + i),
// unnormalised, for D = `views` (LightField layout: one Mat per view) and slope k, into outs[k]'s
// rows from y - firstOutRow. Each source row is read once for all slopes while it is
// in cache (the pass is bound by reading the light field), and each slope's sums run
// in the same order as for that slope alone. Only in-view taps count.
void shiftAndSumRows(const LightField& lf, const std::vector<cv::Mat>& views,
                     const std::vector<SlopeShifts>& shifts, int yBegin, int yEnd,
                     std::vector<float>& rows, const std::vector<cv::Mat*>& outs,
                     int firstOutRow) {
  const int T = lf.T, S = lf.S, V = lf.V, U = lf.U, K = int(shifts.size());
  for (int k = 0; k < K; ++k)
    for (int y = yBegin; y < yEnd; ++y) std::fill_n(outs[k]->ptr<float>(y - firstOutRow), U, 0.f);
  std::vector<int> first(K), last(K);  // per slope: its source rows [first, last)
  std::vector<size_t> block(K);          // and where its H rows start in `rows`
  std::vector<const float*> src(S);      // one source row of each view of a view row
  for (int t = 0; t < T; ++t) {
    // Source rows [first_k, last_k) of view row t feed output rows [yBegin, yEnd) of
    // slope k; each source row is read once for the slopes whose range holds it.
    int r0 = V, r1 = 0;
    size_t size = 0;
    for (int k = 0; k < K; ++k) {
      first[k] = std::max(0, yBegin + shifts[k].y[t].whole);
      last[k] = std::max(first[k], std::min(V, yEnd + shifts[k].y[t].whole + 1));
      block[k] = size;
      size += size_t(last[k] - first[k]) * U;
      if (first[k] < last[k]) {
        r0 = std::min(r0, first[k]);
        r1 = std::max(r1, last[k]);
      }
    }
    if (r0 >= r1) continue;
    rows.resize(size);
    for (int r = r0; r < r1; ++r) {
      for (int s = 0; s < S; ++s) src[s] = views[size_t(t) * S + s].ptr<float>(r);
      for (int k = 0; k < K; ++k)
        if (r >= first[k] && r < last[k])
          sumShiftedRows(src.data(), shifts[k].x.data(), S, U, shifts[k].interior,
                         rows.data() + block[k] + size_t(r - first[k]) * U);
    }
    for (int k = 0; k < K; ++k) {
      const Shift& yShift = shifts[k].y[t];
      const float* h = rows.data() + block[k];
      const float w0 = 1.f - yShift.frac, w1 = yShift.frac;
      for (int y = yBegin; y < yEnd; ++y) {
        float* dst = outs[k]->ptr<float>(y - firstOutRow);
        const int y0 = y + yShift.whole;
        if (y0 >= first[k] && y0 < last[k]) addScaled(h + size_t(y0 - first[k]) * U, w0, U, dst);
        if (y0 + 1 >= first[k] && y0 + 1 < last[k] && w1 > 0.f)
          addScaled(h + size_t(y0 + 1 - first[k]) * U, w1, U, dst);
      }
    }
  }
}

}  // namespace

void renderFocalSlices(const LightField& lf, const std::vector<double>& slopes,
                       const std::vector<cv::Mat*>& slices) {
  CV_Assert(slopes.size() == slices.size());
  const int T = lf.T, S = lf.S, V = lf.V, U = lf.U, K = int(slopes.size());
  if (K == 0) return;
  const double tc = 0.5 * (T - 1), sc = 0.5 * (S - 1);
  // Without alpha every sample weighs 1 and the weight that falls inside the views
  // is separable, Wx(x) * Wy(y); with alpha it is the same shift-and-sum applied to
  // the weights (the values are premultiplied), so F = sum(w L) / sum(w).
  const bool weighted = !lf.weights.empty();
  std::vector<SlopeShifts> shifts(K);
  for (int k = 0; k < K; ++k) {
    for (int s = 0; s < S; ++s) shifts[k].x.emplace_back(-slopes[k] * (s - sc));
    for (int t = 0; t < T; ++t) shifts[k].y.emplace_back(-slopes[k] * (t - tc));
    shifts[k].interior = Interior(shifts[k].x, U);
    if (!weighted) {
      shifts[k].wx = insideWeight(shifts[k].x, U);
      shifts[k].wy = insideWeight(shifts[k].y, V);
    }
    slices[k]->create(V, U, CV_32F);
  }

  const float noSample = kNoSampleWeight * (weighted ? lf.maxWeight : 1.f);
  const int taskRows = rowsPerTask(V), tasks = (V + taskRows - 1) / taskRows;
  parallelFor("focal stack", cv::Range(0, tasks), [&](const cv::Range& range) {
    StageTimer timer(kFocalStack);
    // H_kt for the source rows one task needs: kept by the thread from call to call (up
    // to a few hundred kB), so that a call allocates, and page-faults, nothing here.
    thread_local std::vector<float> rows;
    std::vector<cv::Mat> weightSums(weighted ? K : 0);  // sum(w) of this task's rows
    std::vector<cv::Mat*> weightOuts;
    for (cv::Mat& sum : weightSums) {
      sum.create(taskRows, U, CV_32F);
      weightOuts.push_back(&sum);
    }
    for (int task = range.start; task < range.end; ++task) {
      const int yBegin = task * taskRows, yEnd = std::min(V, yBegin + taskRows);
      shiftAndSumRows(lf, lf.views, shifts, yBegin, yEnd, rows, slices, 0);
      if (weighted)
        shiftAndSumRows(lf, lf.weights, shifts, yBegin, yEnd, rows, weightOuts, yBegin);
      // Normalise by the weight that fell inside the views: near the centre at least
      // 1 per axis without alpha; with alpha it is 0 where no valid sample reaches,
      // and those pixels are set to 0 (the test is relative to the largest weight,
      // since scaling every weight changes nothing else).
      for (int k = 0; k < K; ++k)
        for (int y = yBegin; y < yEnd; ++y) {
          float* out = slices[k]->ptr<float>(y);
          const float* ws = weighted ? weightSums[k].ptr<float>(y - yBegin) : nullptr;
          const float* wx = shifts[k].wx.data();
          const float wy = weighted ? 0.f : shifts[k].wy[y];
          for (int x = 0; x < U; ++x) {
            const float w = weighted ? ws[x] : wx[x] * wy;
            out[x] = w > noSample ? out[x] / w : 0.f;
          }
        }
    }
  });
}

void FocalSliceSource::prepare(const std::vector<int>& which) {
  std::vector<int> group;
  for (int k : which)
    if (!ready_.count(k)) group.push_back(k);
  if (group.empty()) return;
  // Fill the pass with the slopes that come next, holding at most `ahead_` slices
  // (or just the ones asked for, if more).
  int k = std::max(next_, *std::max_element(group.begin(), group.end()) + 1);
  for (; int(group.size() + ready_.size()) < ahead_ && k < int(slopes_.size()); ++k)
    if (!ready_.count(k) && std::find(group.begin(), group.end(), k) == group.end())
      group.push_back(k);
  std::vector<double> slopes;
  std::vector<cv::Mat*> outputs;
  for (int g : group) {
    slopes.push_back(slopes_[g]);
    outputs.push_back(&ready_[g]);
  }
  renderFocalSlices(lf_, slopes, outputs);
  next_ = std::max(next_, *std::max_element(group.begin(), group.end()) + 1);
}

cv::Mat FocalSliceSource::take(int k) {
  auto it = ready_.find(k);
  CV_Assert(it != ready_.end());
  cv::Mat slice = it->second;
  ready_.erase(it);
  return slice;
}

}  // namespace detail
}  // namespace liff
