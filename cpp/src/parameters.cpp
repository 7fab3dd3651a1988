// The ranges of the detector's parameters (Parameters::check) and their FileStorage
// form; the parameters themselves are listed once in liff/parameters.hpp.
#include <climits>
#include <cmath>
#include <cstdlib>
#include <liff/parameters.hpp>
#include <string>

#include "require.hpp"
#include "slope_plan.hpp"

namespace liff {
namespace {

using detail::require;

// A slope bound: finite within kMaxAbsSlope, or the infinity of its side (automatic).
void checkSlope(const char* name, double v, double automatic) {
  require((std::isfinite(v) && std::abs(v) <= detail::kMaxAbsSlope) || v == automatic,
          cv::format("%s = %g; expected %s (automatic) or a finite value in [-%g, %g]", name, v,
                     automatic < 0 ? "-inf" : "+inf", detail::kMaxAbsSlope, detail::kMaxAbsSlope));
}

// `v` as it was written, as far as a double holds it (4294967297, not 4.29497e+09).
std::string exact(double v) {
  if (std::isnan(v)) return "nan";  // OpenCV reads .nan as -nan
  std::string text = cv::format("%.15g", v);
  if (std::strtod(text.c_str(), nullptr) != v) text = cv::format("%.17g", v);
  return text;
}

// JSON has no infinity (OpenCV's JSON writer would write YAML's .Inf, which no JSON
// parser reads): write() puts an infinite value in a JSON file as one of these strings,
// and read() takes them back in any format.
constexpr const char* kPlusInfinity = "inf";
constexpr const char* kMinusInfinity = "-inf";

// A FileStorage entry as a number, or an error naming the key.
double number(const cv::FileNode& node, const char* key) {
  if (node.isString()) {
    const std::string text = node.string();
    if (text == kPlusInfinity) return HUGE_VAL;
    if (text == kMinusInfinity) return -HUGE_VAL;
  }
  if (!node.isInt() && !node.isReal())
    CV_Error(
        cv::Error::StsBadArg,
        cv::format("LiFF: read() found parameter '%s' of the wrong type; expected a number", key));
  return node.isInt() ? double(int(node)) : double(node);
}

// Entry `key` of `fn` into `value` (kept when absent), with the type's rules.
void readEntry(const cv::FileNode& fn, const char* key, int& value) {
  const cv::FileNode node = fn[key];
  if (node.empty()) return;
  const double v = number(node, key);
  if (v != std::floor(v) || v < INT_MIN || v > INT_MAX)
    CV_Error(cv::Error::StsBadArg,
             cv::format("LiFF: read() found %s = %s; expected an integer in [%d, %d]", key,
                        exact(v).c_str(), INT_MIN, INT_MAX));
  value = int(v);
}
void readEntry(const cv::FileNode& fn, const char* key, double& value) {
  const cv::FileNode node = fn[key];
  if (!node.empty()) value = number(node, key);
}
// A boolean only from 0 or 1 (what write() writes; JSON's false and true), never from
// NaN or another number.
void readEntry(const cv::FileNode& fn, const char* key, bool& value) {
  const cv::FileNode node = fn[key];
  if (node.empty()) return;
  const double v = number(node, key);
  if (v != 0 && v != 1)
    CV_Error(cv::Error::StsBadArg,
             cv::format("LiFF: read() found %s = %s; expected 0 or 1 (false or true)", key,
                        exact(v).c_str()));
  value = v == 1;
}

void writeEntry(cv::FileStorage& fs, const char* key, int value) { fs << key << value; }
void writeEntry(cv::FileStorage& fs, const char* key, double value) {
  if (std::isinf(value) && (fs.getFormat() & cv::FileStorage::FORMAT_MASK) == cv::FileStorage::FORMAT_JSON)
    fs << key << (value > 0 ? kPlusInfinity : kMinusInfinity);
  else
    fs << key << value;
}
// FileStorage has no boolean: 0 or 1, as OpenCV's own algorithms write them.
void writeEntry(cv::FileStorage& fs, const char* key, bool value) { fs << key << int(value); }

}  // namespace

void Parameters::check() const {
  require(nfeatures >= 0, cv::format("nfeatures = %d; expected >= 0 (0 keeps all)", nfeatures));
  require(nOctaveLayers >= 1 && nOctaveLayers <= 32,
          cv::format("nOctaveLayers = %d; expected in [1, 32]", nOctaveLayers));
  require(std::isfinite(contrastThreshold) && contrastThreshold >= 0,
          cv::format("contrastThreshold = %g; expected a finite value >= 0", contrastThreshold));
  require(std::isfinite(edgeThreshold) && edgeThreshold >= 1,
          cv::format("edgeThreshold = %g; expected a finite value >= 1", edgeThreshold));
  require(std::isfinite(sigma) && sigma >= 0.01 && sigma <= 100,
          cv::format("sigma = %g; expected a value in [0.01, 100]", sigma));
  checkSlope("firstSlope", firstSlope, -HUGE_VAL);
  checkSlope("lastSlope", lastSlope, HUGE_VAL);
  require(numSlopes >= 0 && numSlopes <= detail::kMaxSlopes,
          cv::format("numSlopes = %d; expected in [0, %d] (0 = automatic)", numSlopes,
                     detail::kMaxSlopes));
  require(descriptorType == CV_32F || descriptorType == CV_8U,
          cv::format("descriptorType = %d; expected CV_32F (%d) or CV_8U (%d)", descriptorType,
                     CV_32F, CV_8U));
  require(firstOctave == -1 || firstOctave == 0,
          cv::format("firstOctave = %d; expected -1 (views upsampled 2x first, as cv::SIFT) or 0 "
                     "(views at their own size)",
                     firstOctave));
}

void writeParameters(cv::FileStorage& fs, const Parameters& p) {
#define LIFF_WRITE_PARAMETER(Type, name, Name, value, help) writeEntry(fs, #name, p.name);
  LIFF_PARAMETERS(LIFF_WRITE_PARAMETER)
#undef LIFF_WRITE_PARAMETER
}

void readParameters(const cv::FileNode& fn, Parameters& parameters) {
  if (!fn.isMap()) CV_Error(cv::Error::StsBadArg, "LiFF: read() expected a map of parameters");
  Parameters next = parameters;  // everything is checked before `parameters` changes
#define LIFF_READ_PARAMETER(Type, name, Name, value, help) readEntry(fn, #name, next.name);
  LIFF_PARAMETERS(LIFF_READ_PARAMETER)
#undef LIFF_READ_PARAMETER
  next.check();
  checkSlopeOrder(next);
  parameters = next;
}

void checkSlopeOrder(const Parameters& p) {
  require(!(p.firstSlope > p.lastSlope),
          cv::format("firstSlope = %g > lastSlope = %g; expected firstSlope <= lastSlope",
                     p.firstSlope, p.lastSlope));
}

}  // namespace liff
