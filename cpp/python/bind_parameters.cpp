// liff._core.PARAMETERS: the parameter table of liff/parameters.hpp, from which the
// Python create(), its stubs' check and the `liff` command's options are made.
#include <set>
#include <string>

#include "bindings.hpp"
#include "parameter_values.hpp"

namespace liff {
namespace python {

namespace {

template <typename T>
const char* typeName() {
  if constexpr (std::is_same_v<T, bool>) return "bool";
  if constexpr (std::is_same_v<T, int>) return "int";
  return "float";
}

}  // namespace

Parameters parametersFrom(const py::kwargs& kwargs) {
  Parameters parameters;
  std::set<std::string> known;
#define LIFF_FROM_KWARG(Type, name, Name, value, help) \
  known.insert(#name);                                 \
  if (kwargs.contains(#name)) parameters.name = number<Type>(kwargs[#name], #name);
  LIFF_PARAMETERS(LIFF_FROM_KWARG)
#undef LIFF_FROM_KWARG
  for (const auto& item : kwargs) {
    const std::string key = py::str(item.first);
    if (!known.count(key)) {
      std::string names;
      for (const std::string& name : known) names += (names.empty() ? "" : ", ") + name;
      throw py::type_error("unexpected keyword argument '" + key + "'; expected one of " + names);
    }
  }
  return parameters;
}

void BindParameters(py::module_& m) {
  py::list table;
  const Parameters defaults;
#define LIFF_TABLE_ROW(Type, name, Name, value, help) \
  table.append(py::make_tuple(#name, typeName<Type>(), defaults.name, #Name, help));
  LIFF_PARAMETERS(LIFF_TABLE_ROW)
#undef LIFF_TABLE_ROW
  // (name, type, default, accessor suffix, help) per parameter, in create()'s order.
  m.attr("PARAMETERS") = py::tuple(table);
}

}  // namespace python
}  // namespace liff
