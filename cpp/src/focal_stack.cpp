#include "focal_stack.hpp"

#include "hot_loop.hpp"

#include <cmath>

namespace liff {
namespace detail {
namespace {

// Rows of the slice one parallel task renders; fixed, so results never depend on threads.
constexpr int kRowsPerTask = 16;

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

// Adds one view row, sampled at x + shift for every x, into `sum` with the bilinear
// weights (1 - frac, frac); taps outside the row are skipped. Interior columns take
// both taps without tests; the few columns near the borders test each tap.
LIFF_HOT_LOOP void accumulateRow(const float* src, int U, Shift shift, float* sum) {
  const float w0 = 1.f - shift.frac, w1 = shift.frac;
  // Interior: 0 <= x + whole and x + whole + 1 <= U - 1.
  const int begin = std::min(U, std::max(0, -shift.whole));
  const int end = std::max(begin, std::min(U, U - 1 - shift.whole));
  auto edge = [&](int x) {
    const int x0 = x + shift.whole, x1 = x0 + 1;
    if (x0 >= 0 && x0 < U) sum[x] += w0 * src[x0];
    if (x1 >= 0 && x1 < U) sum[x] += w1 * src[x1];
  };
  for (int x = 0; x < begin; ++x) edge(x);
  const float* s0 = src + shift.whole;
  for (int x = begin; x < end; ++x) sum[x] += w0 * s0[x] + w1 * s0[x + 1];
  for (int x = end; x < U; ++x) edge(x);
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

std::vector<double> slopeGrid(double first, double last, int n) {
  std::vector<double> slopes;
  if (n == 1) {
    slopes.push_back(0.5 * (first + last));
    return slopes;
  }
  for (int i = 0; i < n; ++i) slopes.push_back(first + (last - first) * i / double(n - 1));
  slopes.back() = last;  // the formula can round one ulp past `last`
  return slopes;
}

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

// One parallel task of the separable shift-and-sum: output rows [yBegin, yEnd) of
//   out(x, y) = sum_t sum_j wy_tj * H_t(y + whole_t + j, x),
//   H_t(r, x) = sum_s sum_i wx_si * D(t, s, r, x + whole_s + i),
// unnormalised, for D = `views` (a LightField-layout Mat), into out's rows from
// y - firstOutRow. H_t is built once per source row (in `rows`); only in-view taps count.
void shiftAndSumRows(const LightField& lf, const cv::Mat& views, const std::vector<Shift>& xShift,
                     const std::vector<Shift>& yShift, int yBegin, int yEnd,
                     std::vector<float>& rows, cv::Mat& out, int firstOutRow) {
  const int T = lf.T, S = lf.S, V = lf.V, U = lf.U;
  for (int y = yBegin; y < yEnd; ++y) std::fill_n(out.ptr<float>(y - firstOutRow), U, 0.f);
  for (int t = 0; t < T; ++t) {
    // Source rows [r0, r1) of view row t feed output rows [yBegin, yEnd).
    const int r0 = std::max(0, yBegin + yShift[t].whole);
    const int r1 = std::min(V, yEnd + yShift[t].whole + 1);
    if (r0 >= r1) continue;
    rows.assign(size_t(r1 - r0) * U, 0.f);
    for (int r = r0; r < r1; ++r) {
      float* h = rows.data() + size_t(r - r0) * U;
      for (int s = 0; s < S; ++s)
        accumulateRow(views.ptr<float>((t * S + s) * V + r), U, xShift[s], h);
    }
    const float w0 = 1.f - yShift[t].frac, w1 = yShift[t].frac;
    for (int y = yBegin; y < yEnd; ++y) {
      float* dst = out.ptr<float>(y - firstOutRow);
      const int y0 = y + yShift[t].whole;
      if (y0 >= r0 && y0 < r1) addScaled(rows.data() + size_t(y0 - r0) * U, w0, U, dst);
      if (y0 + 1 >= r0 && y0 + 1 < r1 && w1 > 0.f)
        addScaled(rows.data() + size_t(y0 + 1 - r0) * U, w1, U, dst);
    }
  }
}

}  // namespace

void renderFocalSlice(const LightField& lf, double slope, cv::Mat& slice) {
  const int T = lf.T, S = lf.S, V = lf.V, U = lf.U;
  slice.create(V, U, CV_32F);
  const double tc = 0.5 * (T - 1), sc = 0.5 * (S - 1);
  std::vector<Shift> xShift, yShift;
  for (int s = 0; s < S; ++s) xShift.emplace_back(-slope * (s - sc));
  for (int t = 0; t < T; ++t) yShift.emplace_back(-slope * (t - tc));
  // Without alpha every sample weighs 1 and the weight that falls inside the views
  // is separable, Wx(x) * Wy(y); with alpha it is the same shift-and-sum applied to
  // the weights (the values are premultiplied), so F = sum(w L) / sum(w).
  const bool weighted = !lf.weights.empty();
  std::vector<float> wx, wy;
  if (!weighted) {
    wx = insideWeight(xShift, U);
    wy = insideWeight(yShift, V);
  }

  const int tasks = (V + kRowsPerTask - 1) / kRowsPerTask;
  cv::parallel_for_(cv::Range(0, tasks), [&](const cv::Range& range) {
    std::vector<float> rows;  // H_t for the source rows one task needs
    cv::Mat weightSum;        // sum(w) for this task's rows (from yBegin), when weighted
    for (int task = range.start; task < range.end; ++task) {
      const int yBegin = task * kRowsPerTask, yEnd = std::min(V, yBegin + kRowsPerTask);
      shiftAndSumRows(lf, lf.views, xShift, yShift, yBegin, yEnd, rows, slice, 0);
      if (weighted) {
        weightSum.create(kRowsPerTask, U, CV_32F);
        shiftAndSumRows(lf, lf.weights, xShift, yShift, yBegin, yEnd, rows, weightSum, yBegin);
      }
      // Normalise by the weight that fell inside the views: near the centre at least
      // 1 per axis without alpha; with alpha it is 0 where no valid sample reaches,
      // and those pixels are set to 0.
      for (int y = yBegin; y < yEnd; ++y) {
        float* out = slice.ptr<float>(y);
        const float* ws = weighted ? weightSum.ptr<float>(y - yBegin) : nullptr;
        for (int x = 0; x < U; ++x) {
          const float w = weighted ? ws[x] : wx[x] * wy[y];
          out[x] = w > 1e-6f ? out[x] / w : 0.f;
        }
      }
    }
  });
}

}  // namespace detail
}  // namespace liff
