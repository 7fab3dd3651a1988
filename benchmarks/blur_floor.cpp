// Where the scale space's blur stands (issue: speed at the hardware's pace, deliverable
// 1): how fast this CPU runs independent fused multiply-adds, and what the blur
// (cpp/src/blur.cpp) costs per pixel and per unit of kernel radius, on an image that
// stays in cache and on one that does not (the same cost on both: not bound by memory),
// and on rows of a width that is not a multiple of 16 floats, packed and padded (rows
// that start part-way into a cache line make its 16-float loads straddle two). Its
// vector operations per ns against the FMA rate say how far it runs from arithmetic's
// floor (docs/BENCHMARKS.md).
//
// Built with the C++ tests (CMakeLists.txt, target liff_blur_floor); run by hand:
//   build/dev/liff_blur_floor
//
// The blur's operations: for each output pixel and each pass (column, then row), one
// multiply for the centre tap and, per pair of taps i = 1..r, one add (a + b) and one
// fused multiply-add: 2 r + 1 per pass, 4 r + 2 per pixel, over the build's vectors
// (16 floats with AVX-512, 8 with AVX2).
#include <opencv2/core.hpp>

#include <chrono>
#include <cstdio>

#include "blur.hpp"
#include "vec8.hpp"

namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

#if defined(LIFF_VEC8) && defined(__x86_64__)
// Independent fused multiply-adds on 16-float vectors: twelve chains, more than the
// FMA units' latency times their count, so the loop runs at their throughput.
__attribute__((target("arch=x86-64-v4"))) double fmaPerNs(long rounds) {
  using liff::detail::Vec16;
  constexpr int kChains = 12;
  Vec16 sum[kChains], k, c;
  for (int j = 0; j < 16; ++j) {
    k[j] = 0.9999f;
    c[j] = 1e-4f;
  }
  for (int i = 0; i < kChains; ++i)
    for (int j = 0; j < 16; ++j) sum[i][j] = 1.f + 1e-3f * i;
  const Clock::time_point start = Clock::now();
  for (long r = 0; r < rounds; ++r)
    for (int i = 0; i < kChains; ++i) sum[i] = sum[i] * k + c;  // contracted to one FMA
  const double seconds = secondsSince(start);
  float keep = 0;  // every lane of every sum is used, so none of them is optimised away
  for (int i = 0; i < kChains; ++i)
    for (int j = 0; j < 16; ++j) keep += sum[i][j];
  if (keep == 12345.f) std::printf(" ");
  return double(rounds) * kChains / seconds * 1e-9;
}
#endif

}  // namespace

int main() {
  cv::setNumThreads(1);
#if defined(LIFF_VEC8) && defined(__x86_64__)
  if (__builtin_cpu_supports("avx512f"))
    std::printf("16-float FMAs (independent chains): %.2f per ns\n", fmaPerNs(100000000));
  else
    std::printf("no AVX-512 on this CPU: FMA rate not measured\n");
#endif
  // Image sizes: in cache (64 rows) and not (1024 rows) at a width of 16-float multiples;
  // then the Illum-size scene's first-octave width, 1082, with rows packed (each row
  // starting 40 bytes further into a cache line than the last) and padded to 1088.
  struct Case {
    int rows, width, stride;
    const char* what;
  };
  for (const Case& c : {Case{64, 1024, 1024, "in cache"}, Case{1024, 1024, 1024, "beyond L2"},
                        Case{256, 1082, 1082, "rows packed"}, Case{256, 1082, 1088, "rows padded"}}) {
    cv::Mat srcBuffer(c.rows, c.stride, CV_32F), dstBuffer(c.rows, c.stride, CV_32F),
        dogBuffer(c.rows, c.stride, CV_32F);
    cv::Mat src = srcBuffer.colRange(0, c.width), dst = dstBuffer.colRange(0, c.width),
            dog = dogBuffer.colRange(0, c.width);
    cv::randu(src, 0.f, 1.f);
    double nsAt[2] = {0, 0};
    int radiusAt[2] = {0, 0};
    const double sigmas[2] = {1.227, 3.092};  // the scale space's first and widest increments
    for (int s = 0; s < 2; ++s) {
      const liff::detail::GaussianTaps taps = liff::detail::gaussianTaps(sigmas[s]);
      const int repeats = std::max(1, 40 * 1024 / c.rows);
      liff::detail::gaussianBlurRows(src, dst, taps, taps, 0, c.rows, &dog);  // warm
      const Clock::time_point start = Clock::now();
      for (int r = 0; r < repeats; ++r)
        liff::detail::gaussianBlurRows(src, dst, taps, taps, 0, c.rows, &dog);
      nsAt[s] = secondsSince(start) / repeats / (double(c.rows) * c.width) * 1e9;
      radiusAt[s] = taps.radius();
    }
    const double perRadius = (nsAt[1] - nsAt[0]) / (radiusAt[1] - radiusAt[0]);
    // 4 operations per unit of radius per pixel, over 16-float vectors.
    std::printf("%4d x %d (%s): %.3f ns a pixel at radius %d, %.3f at %d (blur and DoG); "
                "per unit of radius %.3f ns = %.2f 16-float operations per ns\n",
                c.rows, c.width, c.what, nsAt[0], radiusAt[0], nsAt[1], radiusAt[1], perRadius,
                4.0 / 16.0 / perRadius);
  }
}
