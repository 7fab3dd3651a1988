// Every parameter of the LiFF detector, defined once.
//
// LIFF_PARAMETERS lists each parameter as X(Type, name, Name, default, help):
// `name` is the create() keyword (OpenCV's spelling), `Name` the getter/setter
// suffix (getName, setName), `help` one line with its unit and range. From this
// list come the Parameters struct below, LiFF's getters and setters, read()/write()
// (FileStorage), the Python module's keywords, getters, setters and defaults
// (liff._core.PARAMETERS), the Python create() and the `liff` command's options.
// Ranges are enforced in one place, Parameters::check() (parameters.cpp).
// Adding a parameter, every edit (each one a test or the compiler asks for), in 9 files
// besides the core's use of it:
//   1. one X line here (at the end: create()'s positional order is this order);
//   2. its range in Parameters::check(), parameters.cpp (tests/detector/
//      test_feature2d_api.py's test_every_numeric_parameter_has_a_range);
//   3. its argument in the positional LiFF::create() overload, declared in liff.hpp and
//      defined in liff.cpp (the definition assigns every table entry by name, so a
//      missing argument does not compile), and a custom value in cpp/tests/test_api.cpp's
//      PositionalCreateTakesTheTablesParametersInTheirOrder (which calls it in order);
//   4. its getter and setter in python/liff/_core.pyi and its keyword in the README's
//      create() signature (tests/detector/test_feature2d_api.py compares both);
//   5. its default, custom value and accessor in tests/detector/test_feature2d_api.py's
//      DEFAULTS, CUSTOM and ACCESSOR (golden values: a changed table fails them), and the
//      parameter count in its message test; a value in tests/cli/
//      test_subcommands_end_to_end.py's `given` (the `liff detect` option);
//   6. its use in the core.
#pragma once

#include <opencv2/core.hpp>

#include <limits>

#define LIFF_PARAMETERS(X)                                                                      \
  X(int, nfeatures, NFeatures, 0,                                                               \
    "keep the nfeatures strongest features by response, with every feature tied with the "      \
    "last one (0 keeps all); >= 0")                                                             \
  X(int, nOctaveLayers, NOctaveLayers, 3, "DoG layers per octave, as cv::SIFT; in [1, 32]")     \
  X(double, contrastThreshold, ContrastThreshold, 0.04,                                         \
    "as cv::SIFT: a feature needs DoG contrast >= contrastThreshold / nOctaveLayers on "        \
    "intensities in [0, 1]; finite, >= 0")                                                      \
  X(double, edgeThreshold, EdgeThreshold, 10.0,                                                 \
    "largest ratio of principal curvatures, as cv::SIFT; finite, >= 1")                         \
  X(double, sigma, Sigma, 1.6, "Gaussian sigma of the base octave, as cv::SIFT; in [0.01, 100]") \
  X(double, firstSlope, FirstSlope, -std::numeric_limits<double>::infinity(),                   \
    "first slope of the focal stack, pixels per view step; -inf: automatic, from the light "    \
    "field (docs/SLOPES.md); else |slope| <= 1e4")                                              \
  X(double, lastSlope, LastSlope, std::numeric_limits<double>::infinity(),                      \
    "last slope of the focal stack, pixels per view step; +inf: automatic, from the light "     \
    "field (docs/SLOPES.md); else |slope| <= 1e4")                                              \
  X(int, numSlopes, NumSlopes, 0,                                                               \
    "focal slices: with a finite range, linspace(firstSlope, lastSlope, numSlopes), and with "  \
    "an automatic one that many evenly over the slopes found; 0: neighbouring slices at most "  \
    "one pixel of parallax apart at the outermost view, 2 / (max(T, S) - 1), and with an "      \
    "automatic range only where the scene has structure; in [0, 4096]")                         \
  X(int, descriptorType, DescriptorType, CV_32F,                                                \
    "descriptor element type, CV_32F (5) or CV_8U (0); SIFT's integers in [0, 255] either way") \
  X(bool, rootSift, RootSift, false,                                                            \
    "RootSIFT normalisation (L1, then square root), which the paper found better for SfM")    \
  X(int, firstOctave, FirstOctave, -1,                                                          \
    "first octave of each focal slice's scale space, as SIFT's: -1 upsamples the views 2x "   \
    "first (cv::SIFT's default; finds the smallest features), 0 starts at the views' own "    \
    "size (the authors' toolbox; about half the time); in [-1, 0]")

namespace liff {

/// The detector's parameters, with their defaults (see LIFF_PARAMETERS).
struct Parameters {
#define LIFF_PARAMETER_FIELD(Type, name, Name, value, help) Type name = value;
  LIFF_PARAMETERS(LIFF_PARAMETER_FIELD)
#undef LIFF_PARAMETER_FIELD

  /// Throws cv::Exception (cv::Error::StsOutOfRange) naming the first parameter out
  /// of its range and the range expected. Ranges that involve two parameters (slope
  /// order) are checked when a light field's slopes are made, since setters change
  /// one parameter at a time.
  void check() const;
};

/// Throws cv::Error::StsOutOfRange if firstSlope > lastSlope: for the whole sets that
/// create() and read() take (setters change one bound at a time, so detection checks
/// the order again when it makes the slopes).
void checkSlopeOrder(const Parameters& parameters);

/// Writes `parameters` as one FileStorage entry per parameter, at the current level.
void writeParameters(cv::FileStorage& fs, const Parameters& parameters);
/// Reads the entries of `node` (a map) over `parameters`; absent entries keep their
/// value. Throws cv::Exception (StsBadArg / StsOutOfRange) for an entry of the wrong
/// type or out of range, leaving `parameters` unchanged.
void readParameters(const cv::FileNode& node, Parameters& parameters);

}  // namespace liff
