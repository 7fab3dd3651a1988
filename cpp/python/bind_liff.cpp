// liff._core.LiFF: the detector behind the Python class liff.LiFF, which subclasses
// it and turns keypoint rows into cv2.KeyPoint objects.
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <liff/hooks.hpp>
#include <liff/liff.hpp>
#include <string>

#include "arrays.hpp"
#include "bindings.hpp"
#include "parameter_values.hpp"

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
  py::class_<SlopeRangeReport>(m, "SlopeRangeReport",
                               "What a detector's last completed call found out about its slope "
                               "range (LiFF.getSlopeRangeReport; liff/liff.hpp). Slopes in pixels "
                               "per view step.")
      .def_readonly("slicesUsed", &SlopeRangeReport::slicesUsed,
                    "Slopes of every focal slice built, increasing (list of float).")
      .def_readonly("searchedSlopes", &SlopeRangeReport::searchedSlopes,
                    "Slopes of the slices searched for extrema (list of float).")
      .def_readonly("T", &SlopeRangeReport::T, "View rows of the light field.")
      .def_readonly("S", &SlopeRangeReport::S, "View columns.")
      .def_readonly("V", &SlopeRangeReport::V, "Pixel rows of a view.")
      .def_readonly("U", &SlopeRangeReport::U, "Pixel columns of a view.")
      .def_readonly("automaticRange", &SlopeRangeReport::automaticRange,
                    "Whether firstSlope = -inf and lastSlope = +inf.")
      .def_readonly("automaticReach", &SlopeRangeReport::automaticReach,
                    "Largest |slope| the automatic range considers (docs/SLOPES.md, \"Bound\"); "
                    "at an automatic end; NaN with a hand-set range (both ends finite) or no "
                    "survey (one or two views along the longer axis).")
      .def_readonly("structureBeyondReach", &SlopeRangeReport::structureBeyondReach,
                    "The survey saw structure at or beyond +-automaticReach (not considered).")
      .def_readonly("surveyFoundNothing", &SlopeRangeReport::surveyFoundNothing,
                    "The automatic range's survey found no structure: [-1, 1] was searched.")
      .def_readonly("featuresFound", &SlopeRangeReport::featuresFound,
                    "Features before nfeatures' cut.")
      .def_readonly("featuresReturned", &SlopeRangeReport::featuresReturned,
                    "Features returned.")
      .def_readonly("featuresAtFirstSlope", &SlopeRangeReport::featuresAtFirstSlope,
                    "Returned features at a hand-set (finite) firstSlope's slice.")
      .def_readonly("featuresAtLastSlope", &SlopeRangeReport::featuresAtLastSlope,
                    "Returned features at a hand-set (finite) lastSlope's slice.")
      .def_readonly("endsSurveyed", &SlopeRangeReport::endsSurveyed,
                    "Whether more than RANGE_END_SHARE of the features sat at hand-set ends, "
                    "so the survey ran to find structure beyond them.")
      .def_readonly("surveyedSlopes", &SlopeRangeReport::surveyedSlopes,
                    "Slopes of the features that survey kept (list of float).");
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
      "getSlopeRangeReport", [](const PyLiFF& s) { return s.impl->getSlopeRangeReport(); },
      "What the last completed call found out about its slope range (SlopeRangeReport: "
      "slices, automatic reach, survey outcome, features at hand-set ends and the survey's "
      "slopes beyond them); docs/SLOPES.md.");
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
  py::module_ hooks = m.def_submodule("_hooks");
  hooks.def(
      "survey",
      [](const PyLiFF& s, const py::array& lf) {
        const cv::Mat image = lightFieldMat(lf);
        py::gil_scoped_release release;
        return hooks::surveySlopes(*s.impl, image);
      },
      "detector"_a, "lf"_a,
      "The slopes (px per view step) of the features the automatic range's survey keeps for "
      "`lf` with `detector`'s parameters, whatever its own range (docs/SLOPES.md).");
  hooks.def(
      "memory_estimate",
      [](const PyLiFF& s) {
        const hooks::MemoryEstimateParts need = hooks::lastMemoryEstimate(*s.impl);
        py::dict parts;
        parts["batch"] = need.batch;
        parts["total"] = need.total;
        parts["light_field"] = need.lightField;
        parts["survey"] = need.survey;
        return parts;
      },
      "detector"_a,
      "The memory estimate (bytes) the detector's last detect, detectAndCompute or compute "
      "call checked its limit with, its main parts and the slices it built at once (batch; "
      "0 before the first call).");
}

}  // namespace python
}  // namespace liff
