#include "arrays.hpp"

#include <cfloat>
#include <climits>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

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

namespace {

// A numpy array over a continuous 2-D Mat's data, which it keeps alive: no copy, and
// its memory, from the core's allocator, goes back to the core's working memory when
// the array is freed, so a later call reuses it (working_memory.hpp).
py::array arrayOver(cv::Mat mat, const py::dtype& dtype) {
  CV_Assert(mat.dims == 2 && mat.isContinuous());
  const py::ssize_t rows = mat.rows, cols = mat.cols * mat.channels();
  auto* owner = new cv::Mat(std::move(mat));
  py::capsule keep(owner, [](void* p) { delete static_cast<cv::Mat*>(p); });
  return py::array(dtype, std::vector<py::ssize_t>{rows, cols},
                   std::vector<py::ssize_t>{py::ssize_t(owner->step[0]),
                                            py::ssize_t(owner->elemSize1())},
                   owner->data, keep);
}

}  // namespace

py::array keypointsToArray(const std::vector<cv::KeyPoint>& keypoints) {
  if (keypoints.empty()) return py::array_t<double>(std::vector<py::ssize_t>{0, 7});
  cv::Mat rows(int(keypoints.size()), 7, CV_64F);
  for (size_t i = 0; i < keypoints.size(); ++i) {
    const cv::KeyPoint& k = keypoints[i];
    double* row = rows.ptr<double>(int(i));
    const double values[7] = {k.pt.x, k.pt.y, k.size, k.angle, k.response, double(k.octave),
                              double(k.class_id)};
    std::copy(values, values + 7, row);
  }
  return arrayOver(rows, py::dtype::of<double>());
}

py::array matToArray(const cv::Mat& mat, int cols) {
  if (mat.empty()) return py::array_t<float>(std::vector<py::ssize_t>{0, cols});
  CV_Assert(mat.cols == cols && (mat.depth() == CV_32F || mat.depth() == CV_8U));
  const cv::Mat continuous = mat.isContinuous() ? mat : mat.clone();
  return arrayOver(continuous, mat.depth() == CV_32F ? py::dtype::of<float>()
                                                     : py::dtype::of<uint8_t>());
}

}  // namespace python
}  // namespace liff
