// The module's exceptions (module_internal.h, "Errors").
#include "module_internal.h"

namespace skinspheres::python {

namespace {

// The Python exception types, by ErrorCode (index 0: the base, skinspheres.Error).
std::array<PyObject*, 10> g_error_types{};

}  // namespace

[[noreturn]] void Throw(const Error& e) { throw LibraryError{e.code, runtime::OneLine(e.message)}; }
[[noreturn]] void ThrowArgument(const std::string& message) {
  throw LibraryError{ErrorCode::kInvalidArgument, message};
}

void NoNul(const std::string& text, const char* what) {
  if (text.find('\0') != std::string::npos) throw py::value_error(std::string(what) + ": embedded null byte");
}

py::str Text(const std::string& text) {
  return py::reinterpret_steal<py::str>(
      PyUnicode_DecodeUTF8(text.data(), static_cast<Py_ssize_t>(text.size()), "replace"));
}
py::list Texts(const std::vector<std::string>& texts) {
  py::list out;
  for (const std::string& t : texts) out.append(Text(t));
  return out;
}

void RegisterErrors(py::module_& m) {
  struct Kind {
    ErrorCode code;
    const char* name;
    PyObject* builtin;
  };
  const Kind kinds[] = {
      {ErrorCode::kFileNotFound, "FileNotFound", PyExc_FileNotFoundError},
      {ErrorCode::kFileUnreadable, "FileUnreadable", PyExc_OSError},
      {ErrorCode::kFormatRejected, "FormatRejected", PyExc_ValueError},
      {ErrorCode::kInvalidData, "InvalidData", PyExc_ValueError},
      {ErrorCode::kVersionMismatch, "VersionMismatch", PyExc_ValueError},
      {ErrorCode::kMismatchedAsset, "MismatchedAsset", PyExc_ValueError},
      {ErrorCode::kInvalidArgument, "InvalidArgument", PyExc_ValueError},
      {ErrorCode::kNotFound, "NotFound", PyExc_LookupError},
      {ErrorCode::kCheckFailed, "CheckFailed", PyExc_RuntimeError},
  };
  PyObject* base = PyErr_NewExceptionWithDoc("skinspheres.Error",
                                             "A skinspheres call failed; str(e) is the library's one-line message and "
                                             "e.code its kind ('file not found', 'invalid data', ...).",
                                             PyExc_Exception, nullptr);
  if (!base) throw py::error_already_set();
  g_error_types[0] = base;
  m.add_object("Error", py::handle(base));
  for (const Kind& k : kinds) {
    py::tuple bases = py::make_tuple(py::handle(base), py::handle(k.builtin));
    const std::string name = std::string("skinspheres.") + k.name;
    PyObject* type = PyErr_NewException(name.c_str(), bases.ptr(), nullptr);
    if (!type) throw py::error_already_set();
    g_error_types[static_cast<size_t>(k.code)] = type;
    m.add_object(k.name, py::handle(type));
  }
  py::register_exception_translator([](std::exception_ptr p) {
    if (!p) return;
    try {
      std::rethrow_exception(p);
    } catch (const LibraryError& e) {
      const size_t index = static_cast<size_t>(e.code);
      PyObject* type = index < g_error_types.size() && g_error_types[index] ? g_error_types[index] : g_error_types[0];
      py::object instance = py::reinterpret_borrow<py::object>(type)(Text(e.message));
      instance.attr("code") = ToString(e.code);
      PyErr_SetObject(type, instance.ptr());
    }
  });
}

}  // namespace skinspheres::python
