#include "light_field.hpp"
#include "profile.hpp"

#include "hot_loop.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

namespace liff {
namespace detail {
namespace {

// Largest light field dimension we accept: keeps T*S*V*U and pyramid sizes in int range.
constexpr int kMaxSide = 1 << 20;

// Rows of a colour or integer view converted to float colour at a time: a band stays
// in cache for its grey conversion (a whole 512 x 512 colour view in float is 3 MB).
constexpr int kConversionRows = 16;

std::string depthName(int depth) {
  switch (depth) {
    case CV_8U: return "uint8";
    case CV_8S: return "int8";
    case CV_16U: return "uint16";
    case CV_16S: return "int16";
    case CV_32S: return "int32";
    case CV_32F: return "float32";
    case CV_64F: return "float64";
    default: return "depth " + std::to_string(depth);
  }
}

// Scale that maps the input depth to [0, 1]: uint8 / 255, uint16 / 65535, float as given.
double unitScale(int depth) {
  switch (depth) {
    case CV_8U: return 1.0 / 255.0;
    case CV_16U: return 1.0 / 65535.0;
    default: return 1.0;
  }
}

// Column of the first NaN or infinite value in a float row, or -1. A float is not
// finite exactly when its exponent bits are all ones; the branch-free OR over the
// row vectorises (cv::checkRange does not), and only a row that has one is searched
// again for its position.
LIFF_HOT_LOOP int firstNonFinite(const float* row, int n) {
  constexpr uint32_t kExponent = 0x7f800000u;
  uint32_t any = 0;
  for (int x = 0; x < n; ++x) {
    uint32_t bits;
    std::memcpy(&bits, row + x, sizeof(bits));
    any |= uint32_t((bits & kExponent) == kExponent);
  }
  if (!any) return -1;
  for (int x = 0; x < n; ++x)
    if (!std::isfinite(row[x])) return x;
  return -1;
}

// Throws naming the first view and pixel of `data` (one Mat per view, LightField
// layout) that is NaN or infinite; views are checked in parallel.
void checkFinite(const std::vector<cv::Mat>& data, const LightField& lf, const char* what) {
  std::vector<int> badRow(data.size(), -1), badCol(data.size(), -1);
  parallelFor("finite check", cv::Range(0, int(data.size())), [&](const cv::Range& range) {
    for (int v = range.start; v < range.end; ++v)
      for (int y = 0; y < lf.V; ++y) {
        const int x = firstNonFinite(data[v].ptr<float>(y), lf.U);
        if (x >= 0) {
          badRow[v] = y;
          badCol[v] = x;
          break;
        }
      }
  });
  for (size_t v = 0; v < badRow.size(); ++v)
    if (badRow[v] >= 0)
      CV_Error(cv::Error::StsBadArg,
               cv::format("LiFF: the light field holds a NaN or infinite %s (view %d, "
                          "t = %d, s = %d, pixel row %d, column %d); expected finite values, "
                          "nominally in [0, 1]",
                          what, int(v), int(v) / lf.S, int(v) % lf.S, badRow[v], badCol[v]));
}

}  // namespace

LightField checkLightField(const cv::Mat& input) {
  if (input.empty())
    CV_Error(cv::Error::StsBadArg,
             "LiFF: the light field is empty; expected a 4-D Mat {T, S, V, U} or a 2-D image");
  const int dims = input.dims;
  if (dims != 2 && dims != 4)
    CV_Error(cv::Error::StsBadArg,
             cv::format("LiFF: the light field has %d dimensions; expected 4 ({T, S, V, U}) "
                        "or 2 (one view, V x U)", dims));
  const int depth = input.depth();
  if (depth != CV_8U && depth != CV_16U && depth != CV_32F && depth != CV_64F)
    CV_Error(cv::Error::StsBadArg,
             "LiFF: the light field has element type " + depthName(depth) +
                 "; expected uint8, uint16, float32 or float64");
  const int channels = input.channels();
  if (channels < 1 || channels > 4)
    CV_Error(cv::Error::StsBadArg,
             cv::format("LiFF: the light field has %d channels; expected 1 (grey), 2 (grey + "
                        "alpha), 3 (BGR) or 4 (BGRA)", channels));

  LightField lf;
  if (dims == 2) {
    lf.T = lf.S = 1;
    lf.V = input.rows;
    lf.U = input.cols;
  } else {
    lf.T = input.size[0];
    lf.S = input.size[1];
    lf.V = input.size[2];
    lf.U = input.size[3];
  }
  for (int n : {lf.T, lf.S, lf.V, lf.U})
    if (n < 1 || n > kMaxSide)
      CV_Error(cv::Error::StsBadSize,
               cv::format("LiFF: light field sizes {T=%d, S=%d, V=%d, U=%d} are out of range; "
                          "expected each in [1, %d]", lf.T, lf.S, lf.V, lf.U, kMaxSide));
  const double total = double(lf.T) * lf.S * lf.V * lf.U;
  if (total > double(INT_MAX))
    CV_Error(cv::Error::StsBadSize,
             cv::format("LiFF: the light field has %.0f samples; at most %d are supported",
                        total, INT_MAX));
  return lf;
}

namespace {
// Bookkeeping of one allocation beyond its data (cv::Mat's reference count and
// alignment, the C allocator's chunk header), at most.
constexpr double kPerAllocationBytes = 128;
}  // namespace

void LightField::allocate(bool withWeights) {
  const size_t count = size_t(T) * S;
  views.resize(count);
  weights.resize(withWeights ? count : 0);
  // One buffer of views one after another, each view's header sharing it, and one of
  // weights (apart, so that dropping all-1 weights frees theirs).
  const cv::Mat viewBuffer(int(count), V * U, CV_32F);
  const cv::Mat weightBuffer = withWeights ? cv::Mat(int(count), V * U, CV_32F) : cv::Mat();
  for (size_t v = 0; v < count; ++v) {
    views[v] = viewBuffer.row(int(v)).reshape(1, V);
    if (withWeights) weights[v] = weightBuffer.row(int(v)).reshape(1, V);
  }
}

namespace {

// View (t, s) of a checked input as a V x U Mat of the input's type, sharing its data:
// in OpenCV the last axis of a Mat is always dense, so a view of a 4-D Mat is rows of
// U samples step[2] bytes apart, continuous or not.
cv::Mat inputView(const cv::Mat& input, int t, int s) {
  if (input.dims == 2) return input;
  const int index[4] = {t, s, 0, 0};
  return cv::Mat(input.size[2], input.size[3], input.type(),
                 const_cast<uchar*>(input.ptr(index)), input.step[2]);
}

// Whether the grey light field is the input's own data: one float channel whose views
// have continuous rows (the views themselves need not be adjacent).
bool usedAsIs(const cv::Mat& input) {
  if (input.channels() != 1 || input.depth() != CV_32F) return false;
  return input.dims == 2 ? input.isContinuous()
                         : input.step[2] == size_t(input.size[3]) * sizeof(float);
}

}  // namespace

double conversionBytes(const cv::Mat& input, const LightField& lf) {
  const int planes = input.channels() % 2 == 0 ? 2 : 1;  // values (and weights)
  // A header per view (and weight map) and the allocator's bookkeeping of each: what
  // matters for many tiny views.
  const double headers = double(lf.T) * lf.S * planes * (sizeof(cv::Mat) + kPerAllocationBytes);
  if (usedAsIs(input)) return headers;
  const double samples = double(lf.T) * lf.S * lf.V * lf.U;
  return headers + samples * sizeof(float) * planes;
}

void convertLightField(const cv::Mat& input, LightField& lf) {
  const int depth = input.depth(), channels = input.channels();
  const bool hasAlpha = channels == 2 || channels == 4;
  const int views = lf.T * lf.S;

  if (usedAsIs(input)) {
    lf.views.resize(views);
    for (int v = 0; v < views; ++v) lf.views[v] = inputView(input, v / lf.S, v % lf.S);
  } else {
    lf.allocate(hasAlpha);
    // Convert view by view, so a colour or integer light field never exists as a
    // whole in float colour.
    const double scale = unitScale(depth);
    parallelFor("conversion", cv::Range(0, views), [&](const cv::Range& range) {
      cv::Mat converted;
      for (int v = range.start; v < range.end; ++v) {
        const cv::Mat src = inputView(input, v / lf.S, v % lf.S);
        cv::Mat& dst = lf.views[v];
        if (channels == 1) {
          src.convertTo(dst, CV_32F, scale);
          continue;
        }
        // Float input is read where it is; other depths are converted to float colour
        // a band of rows at a time, which stays in cache for the grey conversion (each
        // row is converted alone either way, so the values do not depend on the band).
        const int band = depth == CV_32F ? lf.V : kConversionRows;
        for (int r0 = 0; r0 < lf.V; r0 += band) {
          const cv::Range rows(r0, std::min(lf.V, r0 + band));
          if (depth != CV_32F) src.rowRange(rows).convertTo(converted, CV_32F, scale);
          const cv::Mat colour = depth == CV_32F ? src : converted;
          cv::Mat grey = dst.rowRange(rows);
          // Luminance of BGR (ITU-R BT.601, as cv::COLOR_BGR2GRAY), computed in float;
          // the alpha channel (last) is the sample's weight.
          if (channels == 2) cv::extractChannel(colour, grey, 0);
          if (channels == 3) cv::cvtColor(colour, grey, cv::COLOR_BGR2GRAY);
          if (channels == 4) cv::cvtColor(colour, grey, cv::COLOR_BGRA2GRAY);
          if (hasAlpha) {
            cv::Mat weight = lf.weights[v].rowRange(rows);
            cv::extractChannel(colour, weight, channels - 1);
          }
        }
      }
    });
  }

  if (depth == CV_32F || depth == CV_64F) {
    // For 64F input a finite value can still overflow float; check the converted
    // data, view by view in parallel, and report the first bad sample.
    const bool f64 = depth == CV_64F;
    checkFinite(lf.views, lf, f64 ? "value (or one beyond float's range, 3.4e38, which LiFF "
                                    "computes in)" : "value");
    if (hasAlpha)
      checkFinite(lf.weights, lf, f64 ? "alpha (weight) (or one beyond float's range, 3.4e38)"
                                      : "alpha (weight)");
  }
  if (hasAlpha) {
    double minWeight = std::numeric_limits<double>::infinity(), maxWeight = -minWeight;
    for (const cv::Mat& weight : lf.weights) {
      double lo = 0, hi = 0;
      cv::minMaxLoc(weight, &lo, &hi);
      minWeight = std::min(minWeight, lo);
      maxWeight = std::max(maxWeight, hi);
    }
    if (minWeight < 0)
      CV_Error(cv::Error::StsBadArg,
               cv::format("LiFF: the light field's alpha channel holds a negative weight "
                          "(%g); expected per-sample validity weights >= 0", minWeight));
    lf.maxWeight = float(maxWeight);
    if (minWeight == maxWeight && maxWeight == 1.0) {
      lf.weights.clear();  // all samples fully valid: the unweighted focal stack is the same
    } else {
      // Premultiply (views hold w * L) view by view; the views are our own buffers here.
      parallelFor("conversion", cv::Range(0, views), [&](const cv::Range& range) {
        for (int v = range.start; v < range.end; ++v)
          cv::multiply(lf.views[v], lf.weights[v], lf.views[v]);
      });
    }
  }
}

namespace {

// Sizes of `lf` decimated `factor` times (data not allocated).
LightField decimatedSizes(const LightField& lf, int factor) {
  LightField small;
  small.T = lf.T;
  small.S = lf.S;
  small.V = lf.V / factor;
  small.U = lf.U / factor;
  CV_Assert(factor >= 1 && small.V >= 1 && small.U >= 1);
  small.maxWeight = lf.maxWeight;  // averages never exceed it (the test is relative)
  return small;
}

// `from` shrunk `factor` times into `to` (allocated, of the decimated size): area
// averages over the whole factor x factor blocks only (a ragged edge is dropped).
void shrink(const cv::Mat& from, int factor, cv::Mat& to) {
  const cv::Mat view = from.rowRange(0, to.rows * factor).colRange(0, to.cols * factor);
  cv::resize(view, to, to.size(), 0, 0, cv::INTER_AREA);
}

}  // namespace

LightField decimate(const LightField& lf, int factor) {
  LightField small = decimatedSizes(lf, factor);
  small.allocate(!lf.weights.empty());
  parallelFor("survey decimation", cv::Range(0, int(small.views.size())), [&](const cv::Range& range) {
    for (int v = range.start; v < range.end; ++v) {
      shrink(lf.views[v], factor, small.views[v]);
      if (!lf.weights.empty()) shrink(lf.weights[v], factor, small.weights[v]);
    }
  });
  return small;
}

void decimateTwice(const LightField& lf, int first, int second,
                   const std::vector<bool>& keepOnce, LightField& once, LightField& twice) {
  const bool weighted = !lf.weights.empty();
  once = decimatedSizes(lf, first);
  twice = decimatedSizes(once, second);
  twice.allocate(weighted);
  const size_t count = size_t(lf.T) * lf.S;
  CV_Assert(keepOnce.size() == count);
  once.views.resize(count);
  once.weights.resize(weighted ? count : 0);
  for (size_t v = 0; v < count; ++v)
    if (keepOnce[v]) {
      once.views[v].create(once.V, once.U, CV_32F);
      if (weighted) once.weights[v].create(once.V, once.U, CV_32F);
    }
  parallelFor("survey decimation", cv::Range(0, int(count)), [&](const cv::Range& range) {
    cv::Mat value, weight;  // a view decimated once that `once` does not keep
    for (int v = range.start; v < range.end; ++v) {
      cv::Mat& a = keepOnce[v] ? once.views[v] : value;
      a.create(once.V, once.U, CV_32F);
      shrink(lf.views[v], first, a);
      shrink(a, second, twice.views[v]);
      if (!weighted) continue;
      cv::Mat& w = keepOnce[v] ? once.weights[v] : weight;
      w.create(once.V, once.U, CV_32F);
      shrink(lf.weights[v], first, w);
      shrink(w, second, twice.weights[v]);
    }
  });
}

void checkMask(const cv::Mat& mask, cv::Size viewSize) {
  if (mask.empty()) return;
  if (mask.type() != CV_8UC1 || mask.dims != 2)
    CV_Error(cv::Error::StsBadArg,
             cv::format("LiFF: the mask has type %s with %d channel(s) and %d dimensions; "
                        "expected a 2-D uint8 single-channel mask",
                        depthName(mask.depth()).c_str(), mask.channels(), mask.dims));
  if (mask.size() != viewSize)
    CV_Error(cv::Error::StsBadSize,
             cv::format("LiFF: the mask is %d x %d (rows x cols); expected the centre view "
                        "size %d x %d", mask.rows, mask.cols, viewSize.height, viewSize.width));
}

}  // namespace detail
}  // namespace liff
