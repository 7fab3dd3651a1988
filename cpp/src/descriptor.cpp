#include "descriptor.hpp"

#include <opencv2/core/hal/hal.hpp>

#include <cfloat>
#include <cmath>
#include <vector>

namespace liff {
namespace detail {

float orientationHistogram(const cv::Mat& image, cv::Point centre, int radius, float sigma,
                           float* hist) {
  const int n = kOrientationBins;
  const float expScale = -1.f / (2.f * sigma * sigma);
  const size_t side = size_t(2 * radius + 1), capacity = side * side;
  // Gather the gradients first, then take exp / atan2 / magnitude in vectorised batches.
  cv::AutoBuffer<float> buffer(capacity * 4 + n + 4);
  float *X = buffer.data(), *Y = X + capacity, *W = Y + capacity, *A = W + capacity;
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

void rawDescriptor(const cv::Mat& image, cv::Point2f point, float angleDegrees, float scale,
                   float* raw) {
  const int d = kDescriptorWidth, n = kDescriptorBins;
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
  cv::AutoBuffer<float> buffer(capacity * 6);
  float *X = buffer.data(), *Y = X + capacity, *W = Y + capacity, *R = W + capacity,
        *C = R + capacity, *O = C + capacity;
  int count = 0;
  for (int i = iBegin; i <= iEnd; ++i) {
    const int y = centre.y + i;
    const float* row = image.ptr<float>(y);
    const float* up = image.ptr<float>(y - 1);
    const float* down = image.ptr<float>(y + 1);
    for (int j = jBegin; j <= jEnd; ++j) {
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

  // Histogram with a guard cell on each side of the grid and two wrap bins.
  std::vector<float> hist(size_t(d + 2) * (d + 2) * (n + 2), 0.f);
  const float angleDeg = angleDegrees, binsPerDegree = n / 360.f;
  for (int k = 0; k < count; ++k) {
    float rBin = R[k], cBin = C[k];
    float oBin = (O[k] - angleDeg) * binsPerDegree;
    const float magnitude = X[k] * W[k];
    // Trilinear interpolation into (row, column, orientation) bins.
    const int r0 = cvFloor(rBin), c0 = cvFloor(cBin);
    int o0 = cvFloor(oBin);
    rBin -= r0;
    cBin -= c0;
    oBin -= o0;
    o0 = ((o0 % n) + n) % n;
    const float vR1 = magnitude * rBin, vR0 = magnitude - vR1;
    const float vRC11 = vR1 * cBin, vRC10 = vR1 - vRC11;
    const float vRC01 = vR0 * cBin, vRC00 = vR0 - vRC01;
    const float vRCO111 = vRC11 * oBin, vRCO110 = vRC11 - vRCO111;
    const float vRCO101 = vRC10 * oBin, vRCO100 = vRC10 - vRCO101;
    const float vRCO011 = vRC01 * oBin, vRCO010 = vRC01 - vRCO011;
    const float vRCO001 = vRC00 * oBin, vRCO000 = vRC00 - vRCO001;
    const size_t idx = (size_t(r0 + 1) * (d + 2) + c0 + 1) * (n + 2) + o0;
    hist[idx] += vRCO000;
    hist[idx + 1] += vRCO001;
    hist[idx + (n + 2)] += vRCO010;
    hist[idx + (n + 3)] += vRCO011;
    hist[idx + (d + 2) * (n + 2)] += vRCO100;
    hist[idx + (d + 2) * (n + 2) + 1] += vRCO101;
    hist[idx + (d + 3) * (n + 2)] += vRCO110;
    hist[idx + (d + 3) * (n + 2) + 1] += vRCO111;
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

}  // namespace detail
}  // namespace liff
