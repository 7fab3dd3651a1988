// One Bind<Area>() per area of liff._core (module.cpp calls them in order).
#pragma once

#include <pybind11/pybind11.h>

namespace liff {
namespace python {

namespace py = pybind11;

void BindParameters(py::module_& m);  // PARAMETERS: the parameter table
void BindLiFF(py::module_& m);        // the detector
void BindThreads(py::module_& m);     // setNumThreads, getNumThreads
void BindVersion(py::module_& m);     // opencvVersion
void BindAllocation(py::module_& m);  // releaseWorkingMemory, keptWorkingMemoryBytes, ...
void BindHooks(py::module_& m);       // _hooks: stage timers and survey, for tests and benchmarks

}  // namespace python
}  // namespace liff
