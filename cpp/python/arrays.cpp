#include "arrays.hpp"

#include <cfloat>
#include <climits>
#include <cmath>
#include <cstring>
#include <string>

namespace liff {
namespace python {
namespace {

const char* kShapes =
    "expected a light field of shape (T, S, V, U) or (T, S, V, U, C), or an image of "
    "shape (V, U) or (V, U, C), with C = 1 (grey), 2 (grey + alpha), 3 (BGR) or 4 (BGRA)";

// OpenCV depth of a numpy dtype, or -1. Compares kind and size, not dtype object
// identity (an equivalent dtype made by newbyteorder('=') is a different object);
// non-native byte order is refused.
int cvDepthOf(const py::dtype& dtype) {
  if (!dtype.attr("isnative").cast<bool>()) return -1;
  const char kind = dtype.kind();
  const py::ssize_t size = dtype.itemsize();
  if (kind == 'u' && size == 1) return CV_8U;
  if (kind == 'u' && size == 2) return CV_16U;
  if (kind == 'f' && size == 4) return CV_32F;
  if (kind == 'f' && size == 8) return CV_64F;
  return -1;
}

std::string shapeOf(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

void requireContiguous(const py::array& a, const char* what) {
  if (!(a.flags() & py::array::c_style))
    throw py::value_error(std::string(what) + " must be C-contiguous (use numpy.ascontiguousarray)");
}

}  // namespace

cv::Mat lightFieldMat(const py::array& array) {
  const int depth = cvDepthOf(array.dtype());
  if (depth < 0)
    throw py::value_error("light field dtype is " + std::string(py::str(array.dtype())) +
                          "; expected uint8, uint16, float32 or float64 (native byte order)");
  const py::ssize_t ndim = array.ndim();
  if (ndim < 2 || ndim > 5)
    throw py::value_error("light field has shape " + shapeOf(array) + "; " + kShapes);
  const bool hasChannels = ndim == 3 || ndim == 5;
  const py::ssize_t channels = hasChannels ? array.shape(ndim - 1) : 1;
  if (channels < 1 || channels > 4)
    throw py::value_error("light field has shape " + shapeOf(array) + " (" +
                          std::to_string(channels) + " channels); " + kShapes);
  if (array.size() == 0)
    throw py::value_error("light field of shape " + shapeOf(array) + " is empty; " + kShapes);
  for (py::ssize_t i = 0; i < ndim; ++i)
    if (array.shape(i) > INT_MAX)
      throw py::value_error("light field shape " + shapeOf(array) + " is too large");
  requireContiguous(array, "the light field");
  const int type = CV_MAKETYPE(depth, int(channels));
  void* data = const_cast<void*>(array.data());
  if (ndim <= 3) return cv::Mat(int(array.shape(0)), int(array.shape(1)), type, data);
  const int sizes[4] = {int(array.shape(0)), int(array.shape(1)), int(array.shape(2)),
                        int(array.shape(3))};
  return cv::Mat(4, sizes, type, data);
}

cv::Mat maskMat(const py::object& mask) {
  if (mask.is_none()) return cv::Mat();
  if (!py::isinstance<py::array>(mask))
    throw py::value_error("mask must be a numpy uint8 array of shape (V, U) or None");
  const py::array a = mask.cast<py::array>();
  // (V, U, 1) is a one-channel image too, as cv2.SIFT takes it.
  const bool plane = a.ndim() == 2 || (a.ndim() == 3 && a.shape(2) == 1);
  if (cvDepthOf(a.dtype()) != CV_8U || !plane || a.size() == 0)
    throw py::value_error("mask has dtype " + std::string(py::str(a.dtype())) + " and shape " +
                          shapeOf(a) + "; expected a non-empty uint8 array of the centre "
                          "view's shape (V, U) or (V, U, 1), or None");
  requireContiguous(a, "the mask");
  return cv::Mat(int(a.shape(0)), int(a.shape(1)), CV_8UC1, const_cast<void*>(a.data()));
}

std::vector<cv::KeyPoint> keypointsFromArray(const py::array& rows) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(rows);
  if (!a || a.ndim() != 2 || a.shape(1) != 7)
    throw py::value_error("keypoint rows must have shape (N, 7): x, y, size, angle, response, "
                          "octave, class_id");
  std::vector<cv::KeyPoint> keypoints(size_t(a.shape(0)));
  auto r = a.unchecked<2>();
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    const double octave = r(i, 5), classId = r(i, 6);
    if (!(std::abs(octave) <= INT_MAX && std::abs(classId) <= INT_MAX))
      throw py::value_error("keypoint " + std::to_string(i) +
                            " has an octave or class_id outside the int range");
    // Values beyond float range become NaN (such keypoints are dropped by compute()).
    auto toFloat = [](double v) { return std::abs(v) <= FLT_MAX ? float(v) : NAN; };
    keypoints[size_t(i)] = cv::KeyPoint(toFloat(r(i, 0)), toFloat(r(i, 1)), toFloat(r(i, 2)),
                                        toFloat(r(i, 3)), toFloat(r(i, 4)), int(octave),
                                        int(classId));
  }
  return keypoints;
}

py::array_t<double> keypointsToArray(const std::vector<cv::KeyPoint>& keypoints) {
  py::array_t<double> out({py::ssize_t(keypoints.size()), py::ssize_t(7)});
  auto w = out.mutable_unchecked<2>();
  for (size_t i = 0; i < keypoints.size(); ++i) {
    const cv::KeyPoint& k = keypoints[i];
    const double row[7] = {k.pt.x, k.pt.y, k.size, k.angle, k.response, double(k.octave),
                           double(k.class_id)};
    for (int j = 0; j < 7; ++j) w(py::ssize_t(i), j) = row[j];
  }
  return out;
}

py::array matToArray(const cv::Mat& mat, int cols) {
  const py::ssize_t rows = mat.empty() ? 0 : mat.rows;
  if (mat.empty() || mat.depth() == CV_32F) {
    py::array_t<float> out({rows, py::ssize_t(cols)});
    for (py::ssize_t i = 0; i < rows; ++i)
      std::memcpy(out.mutable_data(i, 0), mat.ptr<float>(int(i)), sizeof(float) * cols);
    return std::move(out);
  }
  py::array_t<uint8_t> out({rows, py::ssize_t(cols)});
  for (py::ssize_t i = 0; i < rows; ++i)
    std::memcpy(out.mutable_data(i, 0), mat.ptr<uint8_t>(int(i)), cols);
  return std::move(out);
}

}  // namespace python
}  // namespace liff
