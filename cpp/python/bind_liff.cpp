// liff._core.LiFF: the detector behind the Python class liff.LiFF, which subclasses
// it and turns keypoint rows into cv2.KeyPoint objects.
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <liff/liff.hpp>
#include <string>

#include "arrays.hpp"
#include "bindings.hpp"
#include "light_field.hpp"
#include "memory.hpp"
#include "parameter_values.hpp"
#include "slope_range.hpp"

namespace liff {
namespace python {

using namespace pybind11::literals;

namespace {

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

const char* kFileStorageNames = "(.yml, .yaml, .xml or .json)";

void bindAccessors(py::class_<PyLiFF>& cls) {
#define LIFF_BIND_ACCESSORS(Type, name, Name, value, help)                               \
  cls.def(                                                                               \
      "get" #Name, [](const PyLiFF& s) { return s.impl->get##Name(); },                  \
      "Returns " #name ": " help ".");                                                   \
  cls.def(                                                                               \
      "set" #Name,                                                                       \
      [](PyLiFF& s, const py::object& v) { s.impl->set##Name(number<Type>(v, #name)); }, \
      "value"_a, "Sets " #name ": " help ". Raises ValueError if out of range.");
  LIFF_PARAMETERS(LIFF_BIND_ACCESSORS)
#undef LIFF_BIND_ACCESSORS
  cls.def(
      "getMemoryLimitMB", [](const PyLiFF& s) { return s.impl->getMemoryLimitMB(); },
      "Returns the memory limit in MB (see setMemoryLimitMB).");
  cls.def(
      "setMemoryLimitMB",
      [](PyLiFF& s, const py::object& v) {
        s.impl->setMemoryLimitMB(number<double>(v, "memoryLimitMB"));
      },
      "value"_a,
      "Sets the memory limit in MB (0 = automatic: the memory available; inf = none); a "
      "light field that cannot fit raises MemoryError before large allocations. Raises "
      "ValueError if negative.");
}

void bindPersistence(py::class_<PyLiFF>& cls) {
  cls.def(
      "_save",
      [](const PyLiFF& s, const std::string& path) {
        cv::FileStorage fs(path, cv::FileStorage::WRITE);
        if (!fs.isOpened())
          throw py::value_error("cannot write LiFF parameters to '" + path +
                                "'; expected a writable path ending in " + kFileStorageNames);
        s.impl->write(fs);  // at the root, as cv::Feature2D::write(fileName)
      },
      "path"_a, "Writes the parameters to a file with the system OpenCV's FileStorage.");
  cls.def(
      "_read_file",
      [](PyLiFF& s, const std::string& path) {
        const cv::FileStorage fs = openParameterFile(path);  // checks size and nesting
        s.impl->read(fs.root());
      },
      "path"_a, "Reads parameters from a FileStorage file (liff/parameter_file.hpp's limits).");
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
        const cv::FileStorage fs = openParameterText(text, "parameter document");
        s.impl->read(fs.root());
      },
      "text"_a, "Reads parameters from a FileStorage document in memory.");
}

}  // namespace

void BindLiFF(py::module_& m) {
  py::class_<PyLiFF> cls(m, "LiFF", R"doc(
LiFF detector and descriptor (core object; use liff.LiFF, which returns cv2 types).
)doc");
  cls.def(py::init([](const py::kwargs& kwargs) {
            return PyLiFF{LiFF::create(parametersFrom(kwargs))};
          }),
          "Creates a detector from keywords of liff._core.PARAMETERS (the rest default); "
          "raises TypeError for an unknown keyword or a wrong type, ValueError out of range.");
  bindAccessors(cls);
  cls.def(
      "slopesFor", [](const PyLiFF& s, int T, int S) { return s.impl->slopesFor(T, S); }, "T"_a,
      "S"_a,
      "The focal-stack slopes for a light field of T x S views with a finite slope range "
      "(list of float); ValueError with an automatic range.");
  cls.def(
      "_slopes_for_light_field",
      [](PyLiFF& s, const py::array& lf) {
        const cv::Mat image = lightFieldMat(lf);
        py::gil_scoped_release release;
        return s.impl->slopesFor(image);
      },
      "lf"_a, "The focal-stack slopes detection would use for this light field.");
  cls.def(
      "_survey",
      [](PyLiFF& s, const py::array& lf) {
        const cv::Mat image = lightFieldMat(lf);
        Parameters p = s.impl->getParameters();
        py::gil_scoped_release release;
        detail::LightField field = detail::checkLightField(image);
        detail::convertLightField(image, field);
        return detail::surveySlopes(field, p, -HUGE_VAL, HUGE_VAL, std::max(1, cv::getNumThreads()))
            .slopes;
      },
      "lf"_a,
      "The slopes (px per view step) of the features the automatic range's survey keeps for "
      "this light field, whatever this detector's own range (docs/SLOPES.md).");
  cls.def(
      "_survey_found_nothing",
      [](const PyLiFF& s) { return detail::lastSurveyFoundNothing(*s.impl); },
      "Whether the last call's automatic range found no structure in its survey and "
      "searched the paper's [-1, 1] (docs/SLOPES.md).");
  cls.def(
      "_memory_estimate",
      [](const PyLiFF& s) {
        int batch = 0;
        const detail::MemoryEstimate need = detail::lastMemoryEstimate(*s.impl, batch);
        py::dict parts;
        parts["batch"] = batch;
        parts["total"] = batch > 0 ? need.total(batch) : 0.0;
        parts["light_field"] = need.lightFieldBytes;
        parts["survey"] = need.surveyBytes;
        return parts;
      },
      "Tests and benchmarks only: the memory estimate (bytes) the last detect, "
      "detectAndCompute or compute call checked its limit with, its main parts and the "
      "slices it built at once (batch; 0 before the first call).");
  cls.def(
      "getSlicesUsed", [](const PyLiFF& s) { return s.impl->getSlicesUsed(); },
      "Slopes of every focal slice the last call built, increasing (list of float).");
  cls.def(
      "getSearchedSlopes", [](const PyLiFF& s) { return s.impl->getSearchedSlopes(); },
      "Slopes of the slices the last call searched for extrema (list of float).");
  cls.def(
      "descriptorSize", [](const PyLiFF& s) { return s.impl->descriptorSize(); },
      "Descriptor length: 128.");
  cls.def(
      "descriptorType", [](const PyLiFF& s) { return s.impl->descriptorType(); },
      "Descriptor element type: cv2.CV_32F (default) or cv2.CV_8U.");
  cls.def(
      "defaultNorm", [](const PyLiFF& s) { return s.impl->defaultNorm(); },
      "Norm to match descriptors with: cv2.NORM_L2.");
  cls.def(
      "getDefaultName", [](const PyLiFF& s) { return std::string(s.impl->getDefaultName()); },
      "Algorithm name: 'Feature2D.LiFF'.");
  cls.def("empty", [](const PyLiFF& s) { return s.impl->empty(); }, "Always False.");
  cls.def(
      "_run", &run, "lf"_a, "mask"_a = py::none(), "keypoints"_a = py::none(),
      "descriptors"_a = true,
      "Core call: returns (keypoint rows (N, 7) float64, descriptors or None). Releases the GIL.");
  bindPersistence(cls);
  m.def(
      "_automatic_reach",
      [](int T, int S, int V, int U) {
        return detail::surveyed(T, S) ? detail::largestSlope(T, S, V, U) : std::nan("");
      },
      "T"_a, "S"_a, "V"_a, "U"_a,
      "Largest |slope| (px per view step) the automatic range considers for T x S views of "
      "V x U pixels, min(V, U) / (4 (max(T, S) - 1)); NaN where it runs no survey (one or "
      "two views along the longer axis).");
}

}  // namespace python
}  // namespace liff
