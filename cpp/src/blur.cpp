#include "blur.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <map>

#include "hot_loop.hpp"
#include "vec8.hpp"

namespace liff {
namespace detail {
namespace {

// Gaussian kernels gaussianTaps keeps (a few hundred bytes each).
constexpr size_t kKeptKernels = 256;

}  // namespace

GaussianTaps gaussianTaps(double sigma) {
  CV_Assert(sigma > 0);
  // cv::getGaussianKernel computes in soft floating point (~1-3 us a kernel): the
  // scale space asks for the same few sigmas in every batch of every call, so each
  // thread keeps the kernels it made, a bounded number of them (the base blur's sigma
  // varies by slice). Per thread: no lock, nothing shared with a forked child.
  thread_local std::map<double, GaussianTaps> kept;
  auto it = kept.find(sigma);
  if (it != kept.end()) return it->second;
  const int size = cvRound(sigma * 4 * 2 + 1) | 1;  // cv::GaussianBlur's for float images
  const cv::Mat kernel = cv::getGaussianKernel(size, sigma, CV_32F);
  const int radius = size / 2;
  GaussianTaps half;
  half.taps.assign(kernel.ptr<float>() + radius, kernel.ptr<float>() + size);
  if (kept.size() >= kKeptKernels) kept.clear();
  kept.emplace(sigma, half);
  return half;
}

namespace {

// Vectors per step of the inner loops: 4 independent accumulators hide the latency
// of the adds (one dependency chain per vector).
constexpr int kVectors = 4;

}  // namespace

// out[x] = k_0 c(x) + sum_{i=1..r} k_i (a_i(x) + b_i(x)), for x in [0, width), where
// c = rows[r], a_i = rows[r - i], b_i = rows[r + i] (for the horizontal pass, rows
// are one padded row at offsets -r..r). Every x adds in the same order, in the vector
// body and the scalar tail alike, each k_i (a + b) fused into the sum where the build
// has FMA (x86-64-v3 and v4) and not in the baseline build, so a result does not depend
// on where a pixel falls or on the split into stripes; on the CPU only as far as it has
// FMA or not (docs/CONVENTIONS.md).
// With `dog`, also dog[x] = out[x] - before[x] (the DoG of two consecutive Gaussians),
// from the sum still in a register: a separate pass would load `out` again.
LIFF_FMA_LOOP void symmetricTaps(const float* const* rows, const float* taps, int radius,
                                 int width, float* out, const float* before = nullptr,
                                 float* dog = nullptr) {
  int x = 0;
  const float* centre = rows[radius];
#ifdef LIFF_VEC8
  const float k0 = taps[0];  // a scalar operand broadcasts (one vbroadcastss)
  // 16-float vectors: one AVX-512 register each in the v4 build (the horizontal pass is
  // bound by its unaligned loads, half as many per pixel there), two AVX ones in v3.
  constexpr int kWide = 2 * kLanes, kWideVectors = kVectors / 2;
  for (; x + kWide * kWideVectors <= width; x += kWide * kWideVectors) {
    Vec16 acc[kWideVectors];
    for (int v = 0; v < kWideVectors; ++v) acc[v] = k0 * load16(centre + x + v * kWide);
    for (int i = 1; i <= radius; ++i) {
      const float k = taps[i];
      const float* a = rows[radius - i] + x;
      const float* b = rows[radius + i] + x;
      for (int v = 0; v < kWideVectors; ++v)
        acc[v] += k * (load16(a + v * kWide) + load16(b + v * kWide));
    }
    for (int v = 0; v < kWideVectors; ++v) store16(out + x + v * kWide, acc[v]);
    if (dog)
      for (int v = 0; v < kWideVectors; ++v)
        store16(dog + x + v * kWide, acc[v] - load16(before + x + v * kWide));
  }
  for (; x + kLanes <= width; x += kLanes) {
    Vec8 acc = k0 * load(centre + x);
    for (int i = 1; i <= radius; ++i)
      acc += taps[i] * (load(rows[radius - i] + x) + load(rows[radius + i] + x));
    store(out + x, acc);
    if (dog) store(dog + x, acc - load(before + x));
  }
#endif
  for (; x < width; ++x) {
    float acc = taps[0] * centre[x];
    for (int i = 1; i <= radius; ++i) acc += taps[i] * (rows[radius - i][x] + rows[radius + i][x]);
    out[x] = acc;
    if (dog) dog[x] = acc - before[x];
  }
}

// symmetricTaps for two consecutive output rows at once, rows[0 .. 2r + 1] being
// source rows y - r .. y + 1 + r: out0 is row y (centre rows[r]), out1 row y + 1
// (centre rows[r + 1]). Each source row is loaded once for both outputs, which
// halves the loads of the vertical pass (its bound); the arithmetic of each output
// is symmetricTaps's, in the same order, so the result is the same bit for bit.
LIFF_FMA_LOOP void symmetricTapsTwoRows(const float* const* rows, const float* taps, int radius,
                                        int width, float* out0, float* out1, int begin = 0) {
  int x = begin;
  const float k0 = taps[0];
#ifdef LIFF_VEC8
  constexpr int kPair = 2;  // vectors per step: 2 x 2 accumulators and 2 x 2 carried rows
  for (; x + kLanes * kPair <= width; x += kLanes * kPair) {
    Vec8 acc0[kPair], acc1[kPair], low[kPair], high[kPair];
    for (int v = 0; v < kPair; ++v) {
      low[v] = load(rows[radius] + x + v * kLanes);       // row y: y+1's pair at i = 1
      high[v] = load(rows[radius + 1] + x + v * kLanes);  // row y+1: y's pair at i = 1
      acc0[v] = k0 * low[v];
      acc1[v] = k0 * high[v];
    }
    for (int i = 1; i <= radius; ++i) {
      const float k = taps[i];
      const float* above = rows[radius - i] + x;     // y - i
      const float* below = rows[radius + 1 + i] + x;  // y + 1 + i
      for (int v = 0; v < kPair; ++v) {
        const Vec8 a = load(above + v * kLanes), b = load(below + v * kLanes);
        acc0[v] += k * (a + high[v]);  // rows y - i and y + i
        acc1[v] += k * (low[v] + b);   // rows y + 1 - i and y + 1 + i
        low[v] = a;
        high[v] = b;
      }
    }
    for (int v = 0; v < kPair; ++v) {
      store(out0 + x + v * kLanes, acc0[v]);
      store(out1 + x + v * kLanes, acc1[v]);
    }
  }
#endif
  for (; x < width; ++x) {
    float acc0 = k0 * rows[radius][x], acc1 = k0 * rows[radius + 1][x];
    for (int i = 1; i <= radius; ++i) {
      acc0 += taps[i] * (rows[radius - i][x] + rows[radius + i][x]);
      acc1 += taps[i] * (rows[radius + 1 - i][x] + rows[radius + 1 + i][x]);
    }
    out0[x] = acc0;
    out1[x] = acc1;
  }
}

#if defined(LIFF_VEC8) && defined(__x86_64__) && defined(__linux__) && defined(__GNUC__)
#define LIFF_WIDE_ROWS 1
// symmetricTapsTwoRows's vector body in 16-float vectors, two per step (four independent
// sums), built for x86-64-v4 alone: the v3 build could not hold this many vectors in its
// 16 registers. Columns [0, returned) are done; symmetricTapsTwoRows takes the rest.
// The same operations per lane as symmetricTapsTwoRows's, so the same results bit for bit.
__attribute__((target("arch=x86-64-v4"))) int symmetricTapsTwoRowsWide(
    const float* const* rows, const float* taps, int radius, int width, float* out0, float* out1) {
  constexpr int kWide = 2 * kLanes, kPair = 2;
  const float k0 = taps[0];
  int x = 0;
  for (; x + kWide * kPair <= width; x += kWide * kPair) {
    Vec16 acc0[kPair], acc1[kPair], low[kPair], high[kPair];
    for (int v = 0; v < kPair; ++v) {
      low[v] = load16(rows[radius] + x + v * kWide);
      high[v] = load16(rows[radius + 1] + x + v * kWide);
      acc0[v] = k0 * low[v];
      acc1[v] = k0 * high[v];
    }
    for (int i = 1; i <= radius; ++i) {
      const float k = taps[i];
      const float* above = rows[radius - i] + x;
      const float* below = rows[radius + 1 + i] + x;
      for (int v = 0; v < kPair; ++v) {
        const Vec16 a = load16(above + v * kWide), b = load16(below + v * kWide);
        acc0[v] += k * (a + high[v]);
        acc1[v] += k * (low[v] + b);
        low[v] = a;
        high[v] = b;
      }
    }
    for (int v = 0; v < kPair; ++v) {
      store16(out0 + x + v * kWide, acc0[v]);
      store16(out1 + x + v * kWide, acc1[v]);
    }
  }
  return x;
}

// Whether this CPU runs x86-64-v4 code (AVX-512 F, BW, CD, DQ, VL).
bool hasAvx512() {
  static const bool has = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                          __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx512dq") &&
                          __builtin_cpu_supports("avx512vl");
  return has;
}
#endif

void gaussianBlurRows(const cv::Mat& src, cv::Mat& dst, const GaussianTaps& kx,
                      const GaussianTaps& ky, int rowBegin, int rowEnd, cv::Mat* dog) {
  CV_Assert(src.type() == CV_32F && dst.type() == CV_32F && dst.size() == src.size());
  CV_Assert(src.data != dst.data);
  const int width = src.cols, height = src.rows, rx = kx.radius(), ry = ky.radius();
  // Two rows, each padded by rx reflected samples either side, per thread: reused by
  // every call, so a blur allocates nothing.
  const size_t stride = size_t(width) + 2 * rx;
  thread_local std::vector<float> padded;
  thread_local std::vector<const float*> rows, shifted;
  padded.resize(2 * stride);
  rows.resize(2 * ry + 2);
  shifted.resize(2 * rx + 1);
  float* middle[2] = {padded.data() + rx, padded.data() + stride + rx};
  // The horizontal pass of one vertically blurred row (middle[m]) into output row y.
  // Reflected positions of the padding; -j reflects to j and width - 1 + j to
  // width - 1 - j when the row is wider than the kernel's radius.
  const bool wide = width > rx;
  auto horizontal = [&](int m, int y) {
    for (int j = 1; j <= rx; ++j) {
      middle[m][-j] =
          middle[m][wide ? j : cv::borderInterpolate(-j, width, cv::BORDER_REFLECT_101)];
      middle[m][width - 1 + j] = middle[m][wide ? width - 1 - j
                                               : cv::borderInterpolate(width - 1 + j, width,
                                                                       cv::BORDER_REFLECT_101)];
    }
    for (int j = -rx; j <= rx; ++j) shifted[j + rx] = middle[m] + j;
    symmetricTaps(shifted.data(), kx.taps.data(), rx, width, dst.ptr<float>(y),
                  src.ptr<float>(y), dog ? dog->ptr<float>(y) : nullptr);
  };
  for (int y = rowBegin; y < rowEnd;) {
    const int count = std::min(2, rowEnd - y);
    const bool inside = y - ry >= 0 && y + count - 1 + ry < height;  // no reflection
    for (int i = -ry; i <= ry + count - 1; ++i)
      rows[i + ry] = src.ptr<float>(
          inside ? y + i : cv::borderInterpolate(y + i, height, cv::BORDER_REFLECT_101));
    if (count == 2) {
      int done = 0;
#ifdef LIFF_WIDE_ROWS
      if (hasAvx512())
        done = symmetricTapsTwoRowsWide(rows.data(), ky.taps.data(), ry, width, middle[0],
                                        middle[1]);
#endif
      symmetricTapsTwoRows(rows.data(), ky.taps.data(), ry, width, middle[0], middle[1], done);
    }
    else
      symmetricTaps(rows.data(), ky.taps.data(), ry, width, middle[0]);
    for (int m = 0; m < count; ++m) horizontal(m, y + m);
    y += count;
  }
}

namespace {

// One input row upsampled 2x along x (cv::resize's INTER_LINEAR weights, 1/4 and 3/4).
void upsampleLine(const float* in, int width, float* out) {
  out[0] = in[0];
  for (int j = 1; j < width; ++j) {
    out[2 * j - 1] = 0.75f * in[j - 1] + 0.25f * in[j];
    out[2 * j] = 0.25f * in[j - 1] + 0.75f * in[j];
  }
  out[2 * width - 1] = in[width - 1];
}

}  // namespace

// a[x] * wa + b[x] * wb: the vertical weights of the upsample.
LIFF_HOT_LOOP void blendLines(const float* a, float wa, const float* b, float wb, int width,
                              float* out) {
  for (int x = 0; x < width; ++x) out[x] = a[x] * wa + b[x] * wb;
}

void upsample2xRows(const cv::Mat& src, cv::Mat& dst, int rowBegin, int rowEnd) {
  CV_Assert(src.type() == CV_32F && dst.type() == CV_32F);
  CV_Assert(dst.rows == 2 * src.rows && dst.cols == 2 * src.cols);
  const int width = src.cols, height = src.rows, outWidth = dst.cols;
  thread_local std::vector<float> lines;
  lines.resize(2 * size_t(outWidth));
  float* upper = lines.data();
  float* lower = upper + outWidth;
  for (int y = rowBegin; y < rowEnd; ++y) {
    // Output row y samples input row y / 2 - 1/4: rows j - 1 and j for y = 2j
    // (weights 1/4, 3/4), j and j + 1 for y = 2j + 1 (3/4, 1/4), clamped at the ends.
    const int j = y / 2;
    const int other = y % 2 == 0 ? j - 1 : j + 1;
    float* out = dst.ptr<float>(y);
    if (other < 0 || other >= height) {
      upsampleLine(src.ptr<float>(j), width, out);
      continue;
    }
    upsampleLine(src.ptr<float>(std::min(j, other)), width, upper);
    upsampleLine(src.ptr<float>(std::max(j, other)), width, lower);
    if (y % 2 == 0)
      blendLines(upper, 0.25f, lower, 0.75f, outWidth, out);
    else
      blendLines(upper, 0.75f, lower, 0.25f, outWidth, out);
  }
}

}  // namespace detail
}  // namespace liff
