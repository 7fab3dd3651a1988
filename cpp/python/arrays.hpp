// Conversions between numpy arrays and cv::Mat / cv::KeyPoint for the bindings.
// Arrays are wrapped, not copied; the caller keeps them alive while the Mat is used.
#pragma once

#include <opencv2/core.hpp>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <vector>

namespace liff {
namespace python {

namespace py = pybind11;

/// Wraps a C-contiguous numpy light field as a stacked Mat without copying:
/// (V, U) or (V, U, C) -> 2-D Mat; (T, S, V, U) or (T, S, V, U, C) -> 4-D Mat.
/// Raises ValueError naming the expected shapes and dtypes.
cv::Mat lightFieldMat(const py::array& array);

/// Wraps an optional uint8 mask of shape (V, U) or (V, U, 1) (None -> empty Mat).
/// Raises ValueError.
cv::Mat maskMat(const py::object& mask);

/// (N, 7) float64 rows x, y, size, angle, response, octave, class_id <-> keypoints
/// (the rows array, as matToArray, over memory of the core's).
std::vector<cv::KeyPoint> keypointsFromArray(const py::array& rows);
py::array keypointsToArray(const std::vector<cv::KeyPoint>& keypoints);

/// A numpy array over a 2-D CV_32F or CV_8U Mat with `cols` columns, keeping it alive
/// (no copy; its memory returns to the core's working memory when the array is freed).
py::array matToArray(const cv::Mat& mat, int cols);

}  // namespace python
}  // namespace liff
