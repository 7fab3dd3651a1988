#include "arrays.hpp"

#include <liff/liff.hpp>

#include <pybind11/stl.h>

#include <climits>
#include <string>
#include <type_traits>

namespace liff {
namespace python {

using namespace pybind11::literals;

namespace {

// The detector behind the Python class; Python's liff.LiFF subclasses it and turns
// keypoint rows into cv2.KeyPoint objects.
struct PyLiFF {
  cv::Ptr<LiFF> impl;
};

// Runs detection and/or description with the GIL released. `lf` and `mask` stay
// referenced by the caller's frame while the wrapped Mats are in use.
py::tuple run(const PyLiFF& self, const py::array& lf, const py::object& mask,
              const py::object& keypointRows, bool wantDescriptors) {
  const cv::Mat image = lightFieldMat(lf);
  const cv::Mat maskImage = maskMat(mask);
  const bool provided = !keypointRows.is_none();
  std::vector<cv::KeyPoint> keypoints;
  if (provided) keypoints = keypointsFromArray(keypointRows.cast<py::array>());
  cv::Mat descriptors;
  {
    py::gil_scoped_release release;
    if (wantDescriptors)
      self.impl->detectAndCompute(image, maskImage, keypoints, descriptors, provided);
    else
      self.impl->detectAndCompute(image, maskImage, keypoints, cv::noArray(), false);
  }
  py::object desc = py::none();
  if (wantDescriptors) desc = matToArray(descriptors, self.impl->descriptorSize());
  return py::make_tuple(keypointsToArray(keypoints), desc);
}

// Python number -> C++ int or double for parameter `name`. pybind11 alone rejects an
// int beyond C's range as "incompatible function arguments" (TypeError); here such
// values raise ValueError naming the parameter, and non-numbers raise TypeError.
template <typename T>
T number(const py::handle& value, const char* name) {
  const std::string what = std::string(name) + " = " + std::string(py::repr(value));
  if constexpr (std::is_same_v<T, bool>) {
    // Python or numpy bools only (pybind11 would raise RuntimeError for others, or
    // take None and 0.5 as booleans).
    const std::string type = py::str(py::type::of(value).attr("__name__"));
    if (!PyBool_Check(value.ptr()) && type != "bool_" && type != "bool")
      throw py::type_error(what + "; expected a bool");
    return PyObject_IsTrue(value.ptr()) == 1;
  } else if constexpr (std::is_same_v<T, int>) {
    if (PyFloat_Check(value.ptr())) throw py::type_error(what + "; expected an integer");
    const py::object index = py::reinterpret_steal<py::object>(PyNumber_Index(value.ptr()));
    if (!index) {
      PyErr_Clear();
      throw py::type_error(what + "; expected an integer");
    }
    int overflow = 0;
    const long long v = PyLong_AsLongLongAndOverflow(index.ptr(), &overflow);
    if (overflow != 0 || v < INT_MIN || v > INT_MAX)
      throw py::value_error(what + "; expected an integer in the 32-bit range (and see the "
                                   "parameter's own range)");
    return int(v);
  } else {
    const double v = PyFloat_AsDouble(value.ptr());
    if (v == -1.0 && PyErr_Occurred()) {
      const bool overflow = PyErr_ExceptionMatches(PyExc_OverflowError);
      PyErr_Clear();
      if (overflow) throw py::value_error(what + "; expected a value a double can hold");
      throw py::type_error(what + "; expected a number");
    }
    return v;
  }
}

}  // namespace

void BindLiFF(py::module_& m) {
  py::class_<PyLiFF> cls(m, "LiFF", R"doc(
LiFF detector and descriptor (core object; use liff.LiFF, which returns cv2 types).
)doc");
  cls.def(py::init([](const py::object& nfeatures, const py::object& nOctaveLayers,
                      const py::object& contrastThreshold, const py::object& edgeThreshold,
                      const py::object& sigma, const py::object& firstSlope,
                      const py::object& lastSlope, const py::object& numSlopes,
                      const py::object& descriptorType, const py::object& rootSift) {
            return PyLiFF{LiFF::create(
                number<int>(nfeatures, "nfeatures"), number<int>(nOctaveLayers, "nOctaveLayers"),
                number<double>(contrastThreshold, "contrastThreshold"),
                number<double>(edgeThreshold, "edgeThreshold"), number<double>(sigma, "sigma"),
                number<double>(firstSlope, "firstSlope"), number<double>(lastSlope, "lastSlope"),
                number<int>(numSlopes, "numSlopes"), number<int>(descriptorType, "descriptorType"),
                number<bool>(rootSift, "rootSift"))};
          }),
          "nfeatures"_a = 0, "nOctaveLayers"_a = 3, "contrastThreshold"_a = 0.04,
          "edgeThreshold"_a = 10.0, "sigma"_a = 1.6, "firstSlope"_a = -1.0, "lastSlope"_a = 1.0,
          "numSlopes"_a = 0, "descriptorType"_a = int(CV_32F), "rootSift"_a = false,
          "Creates a detector; parameters as liff.LiFF.create.");

// Name: the getter/setter suffix; key: the create() keyword that errors name.
#define LIFF_BIND_PARAM(Name, key, Type, Doc)                                               \
  cls.def("get" #Name, [](const PyLiFF& s) { return s.impl->get##Name(); }, "Returns " Doc); \
  cls.def("set" #Name,                                                                        \
          [](PyLiFF& s, const py::object& v) { s.impl->set##Name(number<Type>(v, #key)); },   \
          "value"_a, "Sets " Doc " Raises ValueError if out of range.");
  LIFF_BIND_PARAM(NFeatures, nfeatures, int, "the number of best features kept (0 = all).")
  LIFF_BIND_PARAM(NOctaveLayers, nOctaveLayers, int, "the number of DoG layers per octave.")
  LIFF_BIND_PARAM(ContrastThreshold, contrastThreshold, double, "the contrast threshold (cv::SIFT meaning).")
  LIFF_BIND_PARAM(EdgeThreshold, edgeThreshold, double, "the edge (principal curvature ratio) threshold.")
  LIFF_BIND_PARAM(Sigma, sigma, double, "the base octave's Gaussian sigma.")
  LIFF_BIND_PARAM(FirstSlope, firstSlope, double, "the first slope of the focal stack (px per view).")
  LIFF_BIND_PARAM(LastSlope, lastSlope, double, "the last slope of the focal stack (px per view).")
  LIFF_BIND_PARAM(NumSlopes, numSlopes, int, "the number of slopes (0 = automatic).")
  LIFF_BIND_PARAM(DescriptorType, descriptorType, int, "the descriptor type, cv2.CV_32F or cv2.CV_8U.")
  LIFF_BIND_PARAM(RootSift, rootSift, bool, "whether descriptors are RootSIFT-normalised.")
  LIFF_BIND_PARAM(MemoryLimitMB, memoryLimitMB, double,
                  "the memory limit in MB (0 = automatic: the memory available; inf = none); "
                  "a light field that cannot fit raises MemoryError before large allocations.")
#undef LIFF_BIND_PARAM

  cls.def("slopesFor", [](const PyLiFF& s, int T, int S) { return s.impl->slopesFor(T, S); },
          "T"_a, "S"_a,
          "The focal-stack slopes used for a light field of T x S views (list of float).");
  cls.def("descriptorSize", [](const PyLiFF& s) { return s.impl->descriptorSize(); },
          "Descriptor length: 128.");
  cls.def("descriptorType", [](const PyLiFF& s) { return s.impl->descriptorType(); },
          "Descriptor element type: cv2.CV_32F (default) or cv2.CV_8U.");
  cls.def("defaultNorm", [](const PyLiFF& s) { return s.impl->defaultNorm(); },
          "Norm to match descriptors with: cv2.NORM_L2.");
  cls.def("getDefaultName", [](const PyLiFF& s) { return std::string(s.impl->getDefaultName()); },
          "Algorithm name: 'Feature2D.LiFF'.");
  cls.def("empty", [](const PyLiFF& s) { return s.impl->empty(); }, "Always False.");
  cls.def(
      "_run", &run, "lf"_a, "mask"_a = py::none(), "keypoints"_a = py::none(),
      "descriptors"_a = true,
      "Core call: returns (keypoint rows (N, 7) float64, descriptors or None). Releases the GIL.");
  cls.def(
      "_save",
      [](const PyLiFF& s, const std::string& path) {
        cv::FileStorage fs(path, cv::FileStorage::WRITE);
        if (!fs.isOpened())
          throw py::value_error("cannot write LiFF parameters to '" + path +
                                "'; expected a writable path ending in .yml, .yaml, .xml or "
                                ".json");
        s.impl->write(fs);  // at the root, as cv::Feature2D::write(fileName)
      },
      "path"_a, "Writes the parameters to a file with the system OpenCV's FileStorage.");
  cls.def(
      "_read_file",
      [](PyLiFF& s, const std::string& path) {
        cv::FileStorage fs;
        try {
          fs.open(path, cv::FileStorage::READ);
        } catch (const cv::Exception& e) {
          throw py::value_error("cannot parse LiFF parameters in '" + path + "' (" + e.err +
                                "); expected an OpenCV FileStorage file (.yml, .yaml, .xml "
                                "or .json)");
        }
        if (!fs.isOpened())
          throw py::value_error("cannot read LiFF parameters from '" + path +
                                "'; expected a readable OpenCV FileStorage file "
                                "(.yml, .yaml, .xml or .json)");
        s.impl->read(fs.root());
      },
      "path"_a, "Reads parameters from a FileStorage file.");
  cls.def(
      "_to_string",
      [](const PyLiFF& s) {
        cv::FileStorage fs(".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
        s.impl->write(fs);
        return std::string(fs.releaseAndGetString());
      },
      "The parameters as a YAML FileStorage document.");
  cls.def(
      "_from_string",
      [](PyLiFF& s, const std::string& text) {
        cv::FileStorage fs(text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
        if (!fs.isOpened()) throw py::value_error("not a FileStorage document");
        s.impl->read(fs.root());
      },
      "text"_a, "Reads parameters from a FileStorage document in memory.");
}

}  // namespace python
}  // namespace liff
