#include "light_field.hpp"

#include "hot_loop.hpp"

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace liff {
namespace detail {
namespace {

// Largest light field dimension we accept: keeps T*S*V*U and pyramid sizes in int range.
constexpr int kMaxSide = 1 << 20;

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

// Throws naming the first view and pixel of `data` (LightField row layout) that is
// NaN or infinite; views are checked in parallel.
void checkFinite(const cv::Mat& data, const LightField& lf, const char* what) {
  CV_Assert(data.type() == CV_32F);
  std::vector<int> badRow(size_t(lf.T) * lf.S, -1), badCol(size_t(lf.T) * lf.S, -1);
  cv::parallel_for_(cv::Range(0, lf.T * lf.S), [&](const cv::Range& range) {
    for (int v = range.start; v < range.end; ++v)
      for (int y = 0; y < lf.V; ++y) {
        const int x = firstNonFinite(data.ptr<float>(v * lf.V + y), lf.U);
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

// Whether the grey light field is the input's own data: one float channel, continuous
// (a 4-D input that is not is first copied into a continuous one, then used as is).
bool usedAsIs(const cv::Mat& input) {
  return input.channels() == 1 && input.depth() == CV_32F &&
         (input.isContinuous() || input.dims == 4);
}

}  // namespace

double conversionBytes(const cv::Mat& input, const LightField& lf) {
  const double samples = double(lf.T) * lf.S * lf.V * lf.U;
  const int channels = input.channels();
  const bool inPlace = usedAsIs(input);
  const bool copied = input.dims == 4 && !input.isContinuous();  // made continuous first
  const double converted = inPlace ? 0 : samples * sizeof(float) * (channels % 2 == 0 ? 2 : 1);
  return converted + (copied ? samples * double(input.elemSize()) : 0);
}

void convertLightField(const cv::Mat& input, LightField& lf) {
  const int dims = input.dims, depth = input.depth(), channels = input.channels();
  const bool hasAlpha = channels == 2 || channels == 4;
  // View the input as (T*S*V) rows of U pixels, with its channels. A 2-D Mat may
  // have any row step; a 4-D sub-array that is not continuous is copied first.
  cv::Mat rows2d;
  if (dims == 2) {
    rows2d = input;
  } else {
    const cv::Mat continuous = input.isContinuous() ? input : input.clone();
    const int rowsU[2] = {lf.T * lf.S * lf.V, lf.U};
    rows2d = continuous.reshape(0, 2, rowsU);  // shares data and reference count
  }

  cv::Mat grey, weights;
  if (usedAsIs(input)) {
    grey = rows2d;  // no copy: we never write to it
  } else {
    // Convert view by view, so a colour or integer light field never exists as a
    // whole in float colour.
    grey.create(lf.T * lf.S * lf.V, lf.U, CV_32F);
    if (hasAlpha) weights.create(grey.size(), CV_32F);
    const double scale = unitScale(depth);
    cv::parallel_for_(cv::Range(0, lf.T * lf.S), [&](const cv::Range& range) {
      cv::Mat converted;
      for (int v = range.start; v < range.end; ++v) {
        const cv::Range rows(v * lf.V, (v + 1) * lf.V);
        const cv::Mat src = rows2d.rowRange(rows);
        cv::Mat dst = grey.rowRange(rows);
        if (channels == 1) {
          src.convertTo(dst, CV_32F, scale);
          continue;
        }
        // Float input is read where it is; other depths are converted view by view.
        if (depth != CV_32F) src.convertTo(converted, CV_32F, scale);
        const cv::Mat& colour = depth == CV_32F ? src : converted;
        // Luminance of BGR (ITU-R BT.601, as cv::COLOR_BGR2GRAY), computed in float;
        // the alpha channel (last) is the sample's weight.
        if (channels == 2) cv::extractChannel(colour, dst, 0);
        if (channels == 3) cv::cvtColor(colour, dst, cv::COLOR_BGR2GRAY);
        if (channels == 4) cv::cvtColor(colour, dst, cv::COLOR_BGRA2GRAY);
        if (hasAlpha) {
          cv::Mat alpha = weights.rowRange(rows);
          cv::extractChannel(colour, alpha, channels - 1);
        }
      }
    });
  }

  if (depth == CV_32F || depth == CV_64F) {
    // For 64F input a finite value can still overflow float; check the converted
    // data, view by view in parallel, and report the first bad sample.
    checkFinite(grey, lf, "value");
    if (hasAlpha) checkFinite(weights, lf, "alpha (weight)");
  }
  if (hasAlpha) {
    double minWeight = 0, maxWeight = 0;
    cv::minMaxLoc(weights, &minWeight, &maxWeight);
    if (minWeight < 0)
      CV_Error(cv::Error::StsBadArg,
               cv::format("LiFF: the light field's alpha channel holds a negative weight "
                          "(%g); expected per-sample validity weights >= 0", minWeight));
    lf.maxWeight = float(maxWeight);
    if (minWeight == maxWeight && maxWeight == 1.0) {
      weights.release();  // all samples fully valid: the unweighted focal stack is the same
    } else {
      // Premultiply (views hold w * L) view by view; `grey` is our own buffer here.
      cv::parallel_for_(cv::Range(0, lf.T * lf.S), [&](const cv::Range& range) {
        for (int v = range.start; v < range.end; ++v) {
          cv::Mat view = grey.rowRange(v * lf.V, (v + 1) * lf.V);
          cv::multiply(view, weights.rowRange(v * lf.V, (v + 1) * lf.V), view);
        }
      });
    }
  }
  lf.weights = weights;
  lf.views = grey;
}

LightField decimate(const LightField& lf, int factor) {
  LightField small;
  small.T = lf.T;
  small.S = lf.S;
  small.V = lf.V / factor;
  small.U = lf.U / factor;
  CV_Assert(factor >= 1 && small.V >= 1 && small.U >= 1);
  const int views = lf.T * lf.S;
  small.views.create(views * small.V, small.U, CV_32F);
  if (!lf.weights.empty()) small.weights.create(small.views.size(), CV_32F);
  auto shrink = [&](const cv::Mat& from, cv::Mat& to, int v) {
    // The whole factor x factor blocks only (a ragged edge is dropped).
    const cv::Mat view = from.rowRange(v * lf.V, v * lf.V + small.V * factor)
                             .colRange(0, small.U * factor);
    cv::Mat out = to.rowRange(v * small.V, (v + 1) * small.V);
    cv::resize(view, out, out.size(), 0, 0, cv::INTER_AREA);
  };
  cv::parallel_for_(cv::Range(0, views), [&](const cv::Range& range) {
    for (int v = range.start; v < range.end; ++v) {
      shrink(lf.views, small.views, v);
      if (!lf.weights.empty()) shrink(lf.weights, small.weights, v);
    }
  });
  small.maxWeight = lf.maxWeight;  // averages never exceed it (the test is relative)
  return small;
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
