#include "focal_stack.hpp"

#include <cmath>

namespace liff {
namespace detail {
namespace {

// Rows of the slice one parallel task renders; fixed, so results never depend on threads.
constexpr int kRowsPerTask = 16;

// Integer and fractional parts of a view's shift: sample x + shift = x + whole + frac.
struct Shift {
  int whole;
  float frac;  // in [0, 1)
  explicit Shift(double shift) {
    const double w = std::floor(shift);
    whole = int(w);
    frac = float(shift - w);
  }
};

// Adds one view row, sampled at x + shift for every x, with weight `rowWeight`, into
// `sum` and its tap weights into `weight`. Interior columns take both taps without
// tests; the few columns near the borders test each tap.
void accumulateRow(const float* src, int U, Shift shift, float rowWeight, float* sum,
                   float* weight) {
  const float w0 = rowWeight * (1.f - shift.frac), w1 = rowWeight * shift.frac;
  // Interior: 0 <= x + whole and x + whole + 1 <= U - 1.
  const int begin = std::max(0, -shift.whole), end = std::min(U, U - 1 - shift.whole);
  for (int x = 0; x < std::min(begin, U); ++x) {
    const int x0 = x + shift.whole, x1 = x0 + 1;
    if (x0 >= 0 && x0 < U) { sum[x] += w0 * src[x0]; weight[x] += w0; }
    if (x1 >= 0 && x1 < U) { sum[x] += w1 * src[x1]; weight[x] += w1; }
  }
  const float* s0 = src + shift.whole;
  const float rw = rowWeight;
  for (int x = begin; x < end; ++x) {
    sum[x] += w0 * s0[x] + w1 * s0[x + 1];
    weight[x] += rw;
  }
  for (int x = std::max(end, begin); x < U; ++x) {
    const int x0 = x + shift.whole, x1 = x0 + 1;
    if (x0 >= 0 && x0 < U) { sum[x] += w0 * src[x0]; weight[x] += w0; }
    if (x1 >= 0 && x1 < U) { sum[x] += w1 * src[x1]; weight[x] += w1; }
  }
}

}  // namespace

std::vector<double> slopeGrid(double first, double last, int n) {
  std::vector<double> slopes;
  if (n == 1) {
    slopes.push_back(0.5 * (first + last));
    return slopes;
  }
  for (int i = 0; i < n; ++i) slopes.push_back(first + (last - first) * i / double(n - 1));
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

void renderFocalSlice(const LightField& lf, double slope, cv::Mat& slice) {
  const int T = lf.T, S = lf.S, V = lf.V, U = lf.U;
  slice.create(V, U, CV_32F);
  const double tc = 0.5 * (T - 1), sc = 0.5 * (S - 1);
  std::vector<Shift> xShift, yShift;
  for (int s = 0; s < S; ++s) xShift.emplace_back(-slope * (s - sc));
  for (int t = 0; t < T; ++t) yShift.emplace_back(-slope * (t - tc));

  const int tasks = (V + kRowsPerTask - 1) / kRowsPerTask;
  cv::parallel_for_(cv::Range(0, tasks), [&](const cv::Range& range) {
    std::vector<float> weight(U);
    for (int task = range.start; task < range.end; ++task) {
      const int yEnd = std::min(V, (task + 1) * kRowsPerTask);
      for (int y = task * kRowsPerTask; y < yEnd; ++y) {
        float* sum = slice.ptr<float>(y);
        std::fill(sum, sum + U, 0.f);
        std::fill(weight.begin(), weight.end(), 0.f);
        for (int t = 0; t < T; ++t) {
          // Vertical taps y0 = y + whole (weight 1 - frac) and y0 + 1 (weight frac).
          const int y0 = y + yShift[t].whole;
          const float fy = yShift[t].frac;
          for (int s = 0; s < S; ++s) {
            const float* view = lf.view(t, s);
            if (y0 >= 0 && y0 < V && fy < 1.f)
              accumulateRow(view + size_t(y0) * U, U, xShift[s], 1.f - fy, sum, weight.data());
            if (y0 + 1 >= 0 && y0 + 1 < V && fy > 0.f)
              accumulateRow(view + size_t(y0 + 1) * U, U, xShift[s], fy, sum, weight.data());
          }
        }
        // Normalise by the weight that fell inside the views (>= 0.5 near the centre).
        for (int x = 0; x < U; ++x) sum[x] = weight[x] > 1e-6f ? sum[x] / weight[x] : 0.f;
      }
    }
  });
}

}  // namespace detail
}  // namespace liff
