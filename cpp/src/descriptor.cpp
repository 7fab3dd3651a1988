#include "descriptor.hpp"

#include "extrema.hpp"
#include "hot_loop.hpp"
#include "scale_space.hpp"

#include <opencv2/core/hal/hal.hpp>

#include <cfloat>
#include <climits>
#include <cmath>
#include <vector>

namespace liff {
namespace detail {
namespace {

// Per-thread scratch of at least n floats, kept from call to call (one per user, so
// they never overlap): a cv::AutoBuffer per keypoint had the C allocator map, and the
// kernel fault in, fresh pages for every large window.
enum Scratch { kOrientationScratch, kDescriptorScratch };
float* threadScratch(Scratch which, size_t n) {
  thread_local std::vector<float> buffers[2];
  std::vector<float>& buffer = buffers[which];
  if (buffer.size() < n) buffer.resize(n);
  return buffer.data();
}

}  // namespace

float orientationHistogram(const cv::Mat& image, cv::Point centre, int radius, float sigma,
                           float* hist) {
  const int n = kOrientationBins;
  const float expScale = -1.f / (2.f * sigma * sigma);
  const size_t side = size_t(2 * radius + 1), capacity = side * side;
  // Gather the gradients first, then take exp / atan2 / magnitude in vectorised batches.
  float *X = threadScratch(kOrientationScratch, capacity * 4 + n + 4), *Y = X + capacity, *W = Y + capacity, *A = W + capacity;
  float* temp = A + capacity + 2;  // two guard bins each side for circular smoothing
  int count = 0;
  for (int i = -radius; i <= radius; ++i) {
    const int y = centre.y + i;
    if (y <= 0 || y >= image.rows - 1) continue;
    const float* row = image.ptr<float>(y);
    const float* up = image.ptr<float>(y - 1);
    const float* down = image.ptr<float>(y + 1);
    for (int j = -radius; j <= radius; ++j) {
      const int x = centre.x + j;
      if (x <= 0 || x >= image.cols - 1) continue;
      // Gradient with image y pointing up, so angles run counter-clockwise on screen.
      X[count] = row[x + 1] - row[x - 1];
      Y[count] = up[x] - down[x];
      W[count] = (i * i + j * j) * expScale;
      ++count;
    }
  }
  cv::hal::exp32f(W, W, count);
  cv::hal::fastAtan32f(Y, X, A, count, true);  // degrees in [0, 360)
  cv::hal::magnitude32f(X, Y, X, count);
  for (int k = -2; k < n + 2; ++k) temp[k] = 0.f;
  for (int k = 0; k < count; ++k) {
    int bin = cvRound(A[k] * (n / 360.f));
    if (bin >= n) bin -= n;
    if (bin < 0) bin += n;
    temp[bin] += W[k] * X[k];
  }
  // Circular smoothing with the kernel [1 4 6 4 1] / 16.
  temp[-1] = temp[n - 1];
  temp[-2] = temp[n - 2];
  temp[n] = temp[0];
  temp[n + 1] = temp[1];
  float highest = 0.f;
  for (int i = 0; i < n; ++i) {
    hist[i] = (temp[i - 2] + temp[i + 2]) * (1.f / 16.f) +
              (temp[i - 1] + temp[i + 1]) * (4.f / 16.f) + temp[i] * (6.f / 16.f);
    highest = std::max(highest, hist[i]);
  }
  return highest;
}

namespace {

// Columns j of row offset i whose rotated-grid position can fall inside the open cell
// range (-1, d) on both axes:  -1 < j * a + b < d  for (a, b) = (sinT, i cosT + d/2 - 1/2)
// and (cosT, -i sinT + d/2 - 1/2). Solved in double and widened by one column, so the
// exact float test that follows still decides every sample it keeps; this only skips
// the corners of the bounding square, about half of it, that the test would reject.
void columnRange(int i, float cosT, float sinT, int d, int& jBegin, int& jEnd) {
  double lo = -DBL_MAX, hi = DBL_MAX;
  auto bound = [&](double a, double b) {  // -1 < j a + b < d
    if (std::abs(a) < 1e-12) {
      if (!(b > -2 && b < d + 1)) hi = -DBL_MAX;  // never inside (widened as below)
      return;
    }
    const double j0 = (-1 - b) / a, j1 = (d - b) / a;
    lo = std::max(lo, std::min(j0, j1));
    hi = std::min(hi, std::max(j0, j1));
  };
  const double half = d / 2.0 - 0.5;
  bound(sinT, i * double(cosT) + half);
  bound(cosT, -i * double(sinT) + half);
  if (!(lo <= hi)) {
    jEnd = jBegin - 1;
    return;
  }
  jBegin = std::max(jBegin, int(std::max(double(INT_MIN / 2), std::floor(lo) - 1)));
  jEnd = std::min(jEnd, int(std::min(double(INT_MAX / 2), std::ceil(hi) + 1)));
}

// Samples whose trilinear weights are computed at once (8 floats each, on the stack).
constexpr int kWeightChunk = 256;

// Trilinear weights of each sample's magnitude over its 2 x 2 x 2 neighbouring
// (row, column, orientation) bins, and the index of the first of them in the padded
// histogram. Branch-free so that it vectorises; the scatter that follows is serial.
// floor is taken as int(v) - (v < int(v)), exact for the small finite values here.
LIFF_HOT_LOOP void trilinearWeights(const float* R, const float* C, const float* O,
                                    const float* magnitude, const float* gaussian, int count,
                                    float angleDegrees, int* index, float* weights) {
  const int d = kDescriptorWidth, n = kDescriptorBins;
  const float binsPerDegree = n / 360.f;
  for (int k = 0; k < count; ++k) {
    float rBin = R[k], cBin = C[k];
    float oBin = (O[k] - angleDegrees) * binsPerDegree;
    const float value = magnitude[k] * gaussian[k];
    int r0 = int(rBin), c0 = int(cBin), o0 = int(oBin);
    r0 -= int(rBin < float(r0));
    c0 -= int(cBin < float(c0));
    o0 -= int(oBin < float(o0));
    rBin -= float(r0);
    cBin -= float(c0);
    oBin -= float(o0);
    o0 &= n - 1;  // o0 mod n (n is a power of two)
    const float vR1 = value * rBin, vR0 = value - vR1;
    const float vRC11 = vR1 * cBin, vRC10 = vR1 - vRC11;
    const float vRC01 = vR0 * cBin, vRC00 = vR0 - vRC01;
    float* w = weights + size_t(k) * 8;
    w[1] = vRC00 * oBin;
    w[0] = vRC00 - w[1];
    w[3] = vRC01 * oBin;
    w[2] = vRC01 - w[3];
    w[5] = vRC10 * oBin;
    w[4] = vRC10 - w[5];
    w[7] = vRC11 * oBin;
    w[6] = vRC11 - w[7];
    index[k] = ((r0 + 1) * (d + 2) + c0 + 1) * (n + 2) + o0;
  }
}

}  // namespace

void rawDescriptor(const cv::Mat& image, cv::Point2f point, float angleDegrees, float scale,
                   float* raw) {
  const int d = kDescriptorWidth, n = kDescriptorBins;
  static_assert((kDescriptorBins & (kDescriptorBins - 1)) == 0, "bins: a power of two");
  const cv::Point centre(cvRound(point.x), cvRound(point.y));
  const float angle = angleDegrees * float(CV_PI / 180.0);
  const float expScale = -1.f / (d * d * 0.5f);
  const float cellWidth = kDescriptorCellFactor * scale;
  // Radius covering the rotated (d + 1) x (d + 1) cell grid, bounded by the image diagonal.
  int radius = cvRound(cellWidth * std::sqrt(2.f) * (d + 1) * 0.5f);
  radius = std::min(radius, int(std::sqrt(double(image.cols) * image.cols +
                                          double(image.rows) * image.rows)));
  const float cosT = std::cos(angle) / cellWidth, sinT = std::sin(angle) / cellWidth;

  // Gather samples inside the rotated grid, then take exp / atan2 / magnitude in
  // vectorised batches (as cv::SIFT), then spread them trilinearly. Only samples in
  // the image interior (0 < y, x < size - 1) count, so the window is clipped to it.
  const int iBegin = std::max(-radius, 1 - centre.y), iEnd = std::min(radius, image.rows - 2 - centre.y);
  const int jBegin = std::max(-radius, 1 - centre.x), jEnd = std::min(radius, image.cols - 2 - centre.x);
  const size_t capacity = std::max<size_t>(
      1, size_t(std::max(0, iEnd - iBegin + 1)) * size_t(std::max(0, jEnd - jBegin + 1)));
  float *X = threadScratch(kDescriptorScratch, capacity * 6), *Y = X + capacity, *W = Y + capacity, *R = W + capacity,
        *C = R + capacity, *O = C + capacity;
  int count = 0;
  for (int i = iBegin; i <= iEnd; ++i) {
    const int y = centre.y + i;
    const float* row = image.ptr<float>(y);
    const float* up = image.ptr<float>(y - 1);
    const float* down = image.ptr<float>(y + 1);
    int jFirst = jBegin, jLast = jEnd;
    columnRange(i, cosT, sinT, d, jFirst, jLast);
    for (int j = jFirst; j <= jLast; ++j) {
      const int x = centre.x + j;
      // Sample offset in the keypoint's rotated frame, in cell units.
      const float cRot = j * cosT - i * sinT, rRot = j * sinT + i * cosT;
      const float rBin = rRot + d / 2 - 0.5f, cBin = cRot + d / 2 - 0.5f;
      if (!(rBin > -1 && rBin < d && cBin > -1 && cBin < d)) continue;
      X[count] = row[x + 1] - row[x - 1];
      Y[count] = up[x] - down[x];
      W[count] = (cRot * cRot + rRot * rRot) * expScale;
      R[count] = rBin;
      C[count] = cBin;
      ++count;
    }
  }
  cv::hal::fastAtan32f(Y, X, O, count, true);  // degrees in [0, 360)
  cv::hal::magnitude32f(X, Y, X, count);
  cv::hal::exp32f(W, W, count);

  // Weights first, a chunk of samples at a time (vectorised; bounded scratch, however
  // large the keypoint), then the serial scatter in sample order into a histogram
  // with a guard cell on each side of the grid and two wrap bins.
  float hist[(kDescriptorWidth + 2) * (kDescriptorWidth + 2) * (kDescriptorBins + 2)] = {};
  float weights[kWeightChunk * 8];
  int index[kWeightChunk];
  for (int begin = 0; begin < count; begin += kWeightChunk) {
    const int chunk = std::min(kWeightChunk, count - begin);
    trilinearWeights(R + begin, C + begin, O + begin, X + begin, W + begin, chunk,
                     angleDegrees, index, weights);
    for (int k = 0; k < chunk; ++k) {
      float* h = hist + index[k];
      const float* w = weights + size_t(k) * 8;
      h[0] += w[0];
      h[1] += w[1];
      h[n + 2] += w[2];
      h[n + 3] += w[3];
      h[(d + 2) * (n + 2)] += w[4];
      h[(d + 2) * (n + 2) + 1] += w[5];
      h[(d + 3) * (n + 2)] += w[6];
      h[(d + 3) * (n + 2) + 1] += w[7];
    }
  }
  // Fold the wrap bins and drop the guard cells.
  for (int i = 0; i < d; ++i)
    for (int j = 0; j < d; ++j) {
      const size_t idx = (size_t(i + 1) * (d + 2) + (j + 1)) * (n + 2);
      hist[idx] += hist[idx + n];
      hist[idx + 1] += hist[idx + n + 1];
      for (int k = 0; k < n; ++k) raw[(i * d + j) * n + k] = hist[idx + k];
    }
}

void finishDescriptor(float* raw, bool rootSift, cv::Mat row) {
  const int len = kDescriptorSize;
  // L2-normalise, clamp each entry at 0.2 of the norm, normalise again.
  double norm2 = 0;
  for (int k = 0; k < len; ++k) norm2 += double(raw[k]) * raw[k];
  const float clamp = float(std::sqrt(norm2)) * kDescriptorClamp;
  norm2 = 0;
  for (int k = 0; k < len; ++k) {
    raw[k] = std::min(raw[k], clamp);
    norm2 += double(raw[k]) * raw[k];
  }
  const float inverse = 1.f / std::max(float(std::sqrt(norm2)), FLT_EPSILON);
  for (int k = 0; k < len; ++k) raw[k] *= inverse;
  if (rootSift) {
    // RootSIFT: d <- sqrt(d / |d|_1), which again has unit L2 norm.
    double norm1 = 0;
    for (int k = 0; k < len; ++k) norm1 += raw[k];
    const float inverse1 = 1.f / std::max(float(norm1), FLT_EPSILON);
    for (int k = 0; k < len; ++k) raw[k] = std::sqrt(raw[k] * inverse1);
  }
  if (row.type() == CV_32F) {
    float* out = row.ptr<float>();
    for (int k = 0; k < len; ++k) out[k] = cv::saturate_cast<uchar>(raw[k] * kDescriptorIntScale);
  } else {
    uchar* out = row.ptr<uchar>();
    for (int k = 0; k < len; ++k) out[k] = cv::saturate_cast<uchar>(raw[k] * kDescriptorIntScale);
  }
}

void describeKeypoint(const ScaleSpace& space, const cv::KeyPoint& kp, bool rootSift,
                      cv::Mat row) {
  int o = 0, layer = 0;
  CV_Assert(unpackOctave(kp, space.octaves, space.layers, space.firstOctave, o, layer));
  const cv::Point2f pt(viewToOctave(kp.pt.x, o, space.firstOctave),
                       viewToOctave(kp.pt.y, o, space.firstOctave));
  // Scale in octave pixels: size is a diameter in view pixels.
  const float scale = kp.size * 0.5f / std::ldexp(1.f, o + space.firstOctave);
  // Descriptor rotation, reduced to [0, 360) whatever angle the keypoint carries
  // (cv2.KeyPoint's default is -1).
  float angle = std::fmod(360.f - kp.angle, 360.f);
  if (angle < 0.f) angle += 360.f;
  if (!(angle < 360.f) || std::abs(angle - 360.f) < FLT_EPSILON) angle = 0.f;
  float raw[kDescriptorSize];
  rawDescriptor(space.gaussian(o, layer), pt, angle, scale, raw);
  finishDescriptor(raw, rootSift, row);
}

}  // namespace detail
}  // namespace liff
