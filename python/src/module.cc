// _skinspheres: the native part of the Python module `skinspheres` (python/skinspheres/__init__.py
// re-exports it; _skinspheres.pyi documents its types). It binds the C++ API directly: the fitter
// (fit), the sphere-set formats (load, SphereSet.save), the runtime (Asset, Instance), and the
// tool's own play and check code (play, check), so their results are the CLI's.
//
// Arrays: inputs are numpy arrays of float32 or float64 in any strides (transposed, sliced,
// non-contiguous), read element by element into the instance's buffers, which are sized once: a
// frame allocates only its output arrays. float64 becomes float32 by rounding to nearest, as
// numpy's astype does. Outputs are new numpy arrays (structured for pairs and contacts) that the
// caller owns. Matrices are (J, 4, 4) in the usual mathematical layout: world[j] @ [x, y, z, 1]
// moves a point, the translation is world[j, :3, 3].
//
// Threads: every call that runs more than a few microseconds releases the GIL (fit, play, check,
// the updates and the contact searches). An Instance is one character's state: using one from two
// threads at once raises (it is never a data race); distinct instances run in parallel.
//
// Errors: the library's one-line messages, as Python exceptions (skinspheres.Error and its
// subclasses, which also derive from the matching built-in: FileNotFoundError, ValueError, ...);
// wrong argument types raise TypeError.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <initializer_list>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "check.h"
#include "clip_files.h"
#include "commands.h"
#include "playback.h"
#include "skinspheres/lib/io/clip_import.h"
#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/api/joint_mapping.h"
#include "skinspheres/runtime/format/file_io.h"
#include "skinspheres/runtime/format/sphere_set_io.h"
#include "skinspheres/version.h"

namespace py = pybind11;

namespace skinspheres::python {
// A path argument: str, bytes or os.PathLike, as UTF-8 (what the library's readers take on every
// platform). ValueError, as Python's own open() gives, for a NUL byte (the C++ side would cut the
// path there) or bytes that are not UTF-8.
struct PathText {
  std::string value;
};
}  // namespace skinspheres::python

namespace pybind11::detail {
template <>
struct type_caster<skinspheres::python::PathText> {
  PYBIND11_TYPE_CASTER(skinspheres::python::PathText, const_name("os.PathLike"));
  bool load(handle source, bool) {
    PyObject* fs = PyOS_FSPath(source.ptr());
    if (!fs) {
      PyErr_Clear();
      return false;  // not a path: TypeError from the dispatcher
    }
    object path = reinterpret_steal<object>(fs);
    if (PyUnicode_Check(path.ptr())) {
      Py_ssize_t size = 0;
      const char* text = PyUnicode_AsUTF8AndSize(path.ptr(), &size);
      if (!text) {
        PyErr_Clear();
        throw value_error("path: not encodable as UTF-8");
      }
      value.value.assign(text, static_cast<size_t>(size));
    } else {
      char* bytes = nullptr;
      Py_ssize_t size = 0;
      if (PyBytes_AsStringAndSize(path.ptr(), &bytes, &size) != 0) {
        PyErr_Clear();
        return false;
      }
      value.value.assign(bytes, static_cast<size_t>(size));
      PyObject* check = PyUnicode_DecodeUTF8(bytes, size, "strict");
      if (!check) {
        PyErr_Clear();
        throw value_error("path: bytes that are not UTF-8 (the library reads UTF-8 paths)");
      }
      Py_DECREF(check);
    }
    if (value.value.find('\0') != std::string::npos) throw value_error("path: embedded null byte");
    return true;
  }
  static handle cast(const skinspheres::python::PathText& p, return_value_policy, handle) {
    return PyUnicode_DecodeUTF8(p.value.data(), static_cast<Py_ssize_t>(p.value.size()), "replace");
  }
};
}  // namespace pybind11::detail

namespace skinspheres::python {
namespace {

// ---- Errors ----

// The Python exception types, by ErrorCode (index 0: the base, skinspheres.Error).
std::array<PyObject*, 10> g_error_types{};

struct LibraryError {
  ErrorCode code;
  std::string message;
};

[[noreturn]] void Throw(const Error& e) { throw LibraryError{e.code, runtime::OneLine(e.message)}; }
[[noreturn]] void ThrowArgument(const std::string& message) {
  throw LibraryError{ErrorCode::kInvalidArgument, message};
}

// A file name given as text (a joint map, a rest rig, a parts file): the C++ side would cut it at a
// NUL byte and read another file.
void NoNul(const std::string& text, const char* what) {
  if (text.find('\0') != std::string::npos) throw py::value_error(std::string(what) + ": embedded null byte");
}

// play(frames=...): at most this many (a day at 30 fps would be 2.6 million; the per-frame arrays
// grow with it, and the call cannot be interrupted while it runs).
constexpr int64_t kMaxPlayFrames = 1000000;

template <typename T>
T Take(Result<T> r) {
  if (!r.ok()) Throw(r.error());
  return std::move(r).value();
}

// Text the library holds (names and paths from files) as str: invalid UTF-8 is replaced, never an
// exception on reading a property.
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

// ---- Array input ----

// A float32 or float64 array of the given shape (-1: any length >= min_first on the first axis),
// any strides. TypeError for another dtype, InvalidArgument for another shape.
// At most 4 axes (the frame loop's (F, J, 4, 4)); fixed arrays, so reading a frame's input
// allocates nothing.
constexpr size_t kMaxAxes = 4;

struct FloatArray {
  const char* data = nullptr;
  bool f64 = false;
  std::array<py::ssize_t, kMaxAxes> shape{}, strides{};

  // The element at `index` (one entry per axis) as float.
  float At(std::initializer_list<py::ssize_t> index) const {
    const char* p = data;
    size_t axis = 0;
    for (py::ssize_t i : index) p += i * strides[axis++];
    if (f64) {
      double v;
      std::memcpy(&v, p, sizeof v);
      return static_cast<float>(v);  // round to nearest, as numpy's astype(float32)
    }
    float v;
    std::memcpy(&v, p, sizeof v);
    return v;
  }
};

// numpy.ma.MaskedArray, looked up once at import (not on every frame).
py::object g_masked_array_type;

// "(N, 4, 4)": a shape as a message shows it (-1: any length).
std::string ShapeText(std::initializer_list<py::ssize_t> dims) {
  std::string text = "(";
  size_t d = 0;
  for (py::ssize_t n : dims) {
    text += (d ? ", " : "") + (n < 0 ? std::string(d == 0 ? "N" : "?") : std::to_string(n));
    ++d;
  }
  return text + (dims.size() == 1 ? ",)" : ")");
}

// `object` as a float32 or float64 array of shape `want` (-1: any length on that axis), any
// strides. TypeError for another type or dtype, InvalidArgument for another shape.
FloatArray ReadFloatArray(const py::handle& object, const char* what, std::initializer_list<py::ssize_t> want) {
  if (!py::isinstance<py::array>(object)) {
    throw py::type_error(std::string(what) + ": expected a numpy array of float32 or float64, got " +
                         std::string(py::str(py::type::of(object).attr("__name__"))));
  }
  if (py::isinstance(object, g_masked_array_type)) {
    throw py::type_error(std::string(what) + ": a masked array (its mask would be ignored): pass .filled() or .data");
  }
  auto a = py::reinterpret_borrow<py::array>(object);
  FloatArray out;
  const py::dtype dt = a.dtype();
  if (dt.kind() != 'f' || (dt.itemsize() != 4 && dt.itemsize() != 8)) {
    throw py::type_error(std::string(what) + ": expected float32 or float64 elements, got " +
                         std::string(py::str(py::handle(dt))));
  }
  out.f64 = dt.itemsize() == 8;
  if (!(dt.byteorder() == '=' || dt.byteorder() == '|' ||
        (dt.byteorder() == '<') == (py::module_::import("sys").attr("byteorder").cast<std::string>() == "little"))) {
    throw py::type_error(std::string(what) + ": byte-swapped arrays are not read (use .astype(native dtype))");
  }
  bool fits = static_cast<size_t>(a.ndim()) == want.size();
  size_t d = 0;
  for (py::ssize_t n : want) {
    if (!fits) break;
    fits = n < 0 || a.shape(static_cast<py::ssize_t>(d)) == n;
    ++d;
  }
  if (!fits) {
    std::string got = "(";
    for (py::ssize_t k = 0; k < a.ndim(); ++k) got += (k ? ", " : "") + std::to_string(a.shape(k));
    got += a.ndim() == 1 ? ",)" : ")";
    ThrowArgument(std::string(what) + ": expected shape " + ShapeText(want) + ", got " + got);
  }
  out.data = static_cast<const char*>(a.data());
  for (py::ssize_t k = 0; k < a.ndim(); ++k) {
    out.shape[static_cast<size_t>(k)] = a.shape(k);
    out.strides[static_cast<size_t>(k)] = a.strides(k);
  }
  return out;
}

// ---- Array output ----

// The records of the structured arrays (dtypes registered in the module: no padding, so the
// numpy dtypes print as plain field lists). kind: PartContactKind, TriangleContactKind.
struct SpherePairRecord {
  uint32_t i, j;
  float depth;
  uint16_t part_i, part_j;
};
struct PartContactRecord {
  uint16_t part_a, part_b;
  uint32_t kind;  // 0 touching, 1 penetrating
  float depth, min_distance;
  float normal[3], center[3];
  uint32_t triangle_pairs, intersecting, sphere_pairs, first_triangle;
};
struct TriangleContactRecord {
  uint32_t part_contact, triangle_a, triangle_b;
  uint32_t kind;  // 0 intersecting, 1 within margin
  float distance;
  float point[3], on_a[3], on_b[3];
};
// The same with the frame first, for play().
struct FrameSpherePairRecord {
  uint32_t frame;
  uint32_t i, j;
  float depth;
  uint16_t part_i, part_j;
};
struct FramePartContactRecord {
  uint32_t frame;
  uint16_t part_a, part_b;
  uint32_t kind;
  float depth, min_distance;
  float normal[3], center[3];
  uint32_t triangle_pairs, intersecting, sphere_pairs, first_triangle;
};
struct FrameTriangleContactRecord {
  uint32_t frame;
  uint32_t part_contact, triangle_a, triangle_b;
  uint32_t kind;
  float distance;
  float point[3], on_a[3], on_b[3];
};
static_assert(sizeof(SpherePairRecord) == 16 && sizeof(PartContactRecord) == 56 && sizeof(TriangleContactRecord) == 56);
static_assert(sizeof(FrameSpherePairRecord) == 20 && sizeof(FramePartContactRecord) == 60 &&
              sizeof(FrameTriangleContactRecord) == 60);

// A record with its frame: the frame, then the same bytes (both layouts have no padding).
template <typename Framed, typename Record>
Framed WithFrame(uint32_t frame, const Record& r) {
  static_assert(sizeof(Framed) == sizeof(Record) + sizeof(uint32_t));
  Framed out;
  out.frame = frame;
  std::memcpy(reinterpret_cast<char*>(&out) + sizeof(uint32_t), &r, sizeof r);
  return out;
}

template <typename T>
py::array_t<T> NewArray(size_t n) {
  return py::array_t<T>(static_cast<py::ssize_t>(n));
}

SpherePairRecord ToRecord(const runtime::SpherePair& p) { return {p.i, p.j, p.depth, p.part_i, p.part_j}; }

PartContactRecord ToRecord(const runtime::PartContact& p) {
  PartContactRecord r{};
  r.part_a = p.part_a;
  r.part_b = p.part_b;
  r.kind = static_cast<uint32_t>(p.kind);
  r.depth = p.depth;
  r.min_distance = p.min_distance;
  std::memcpy(r.normal, p.normal, sizeof r.normal);
  std::memcpy(r.center, p.center, sizeof r.center);
  r.triangle_pairs = p.triangle_pair_count;
  r.intersecting = p.intersecting_count;
  r.sphere_pairs = p.sphere_pair_count;
  r.first_triangle = p.first_triangle_pair;
  return r;
}

TriangleContactRecord ToRecord(const runtime::TriangleContact& c, uint32_t part_contact) {
  TriangleContactRecord r{};
  r.part_contact = part_contact;
  r.triangle_a = c.t;
  r.triangle_b = c.u;
  r.kind = static_cast<uint32_t>(c.kind);
  r.distance = c.distance;
  std::memcpy(r.point, c.point, sizeof r.point);
  std::memcpy(r.on_a, c.on_t, sizeof r.on_a);
  std::memcpy(r.on_b, c.on_u, sizeof r.on_b);
  return r;
}

py::array SpherePairArray(std::span<const runtime::SpherePair> pairs) {
  auto out = NewArray<SpherePairRecord>(pairs.size());
  auto* dst = out.mutable_data();
  for (size_t k = 0; k < pairs.size(); ++k) dst[k] = ToRecord(pairs[k]);
  return out;
}

// A frame's contacts: (parts, triangles) structured arrays.
py::tuple ContactArrays(const runtime::FrameContacts& contacts) {
  auto parts = NewArray<PartContactRecord>(contacts.parts.size());
  auto triangles = NewArray<TriangleContactRecord>(contacts.triangle_pairs.size());
  auto* p = parts.mutable_data();
  auto* t = triangles.mutable_data();
  for (size_t k = 0; k < contacts.parts.size(); ++k) {
    const runtime::PartContact& pc = contacts.parts[k];
    p[k] = ToRecord(pc);
    for (uint32_t q = pc.first_triangle_pair; q < pc.first_triangle_pair + pc.triangle_pair_count; ++q) {
      t[q] = ToRecord(contacts.triangle_pairs[q], static_cast<uint32_t>(k));
    }
  }
  return py::make_tuple(parts, triangles);
}

template <typename T>
py::array CopyArray(const std::vector<T>& v) {
  auto out = NewArray<T>(v.size());
  if (!v.empty()) std::memcpy(out.mutable_data(), v.data(), v.size() * sizeof(T));
  return out;
}

py::array Vec3Array(const std::vector<Eigen::Vector3f>& v) {
  py::array_t<float> out({static_cast<py::ssize_t>(v.size()), py::ssize_t{3}});
  auto m = out.mutable_unchecked<2>();
  for (size_t k = 0; k < v.size(); ++k) {
    for (int c = 0; c < 3; ++c) m(static_cast<py::ssize_t>(k), c) = v[k][c];
  }
  return out;
}

py::array MatrixArray(std::span<const Mat4f> v) {
  py::array_t<float> out({static_cast<py::ssize_t>(v.size()), py::ssize_t{4}, py::ssize_t{4}});
  auto m = out.mutable_unchecked<3>();
  for (size_t k = 0; k < v.size(); ++k) {
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) m(static_cast<py::ssize_t>(k), r, c) = v[k](r, c);
    }
  }
  return out;
}

std::vector<std::string> PartNames(const runtime::SphereSet& set) {
  std::vector<std::string> names;
  for (const auto& p : set.parts) names.push_back(p.name);
  return names;
}

// ---- SphereSet ----

struct PySphereSet {
  std::shared_ptr<const runtime::SphereSet> set;
  py::dict fit_report;  // empty unless made by fit()
};

PySphereSet Load(const PathText& path_arg) {
  const std::string& path = path_arg.value;
  runtime::SphereSet set;
  {
    py::gil_scoped_release release;
    auto read = runtime::LoadSphereSet(path);
    if (!read.ok()) Throw(read.error());
    set = std::move(read).value();
  }
  return {std::make_shared<const runtime::SphereSet>(std::move(set)), {}};
}

// The fit options as the tool resolves them (method name, hops, flags); InvalidArgument when refused.
tool::FitOptions Resolved(tool::FitOptions options) {
  if (auto why = options.Resolve()) ThrowArgument(*why);
  return options;
}

PySphereSet Fit(const std::optional<PathText>& path, const tool::FitOptions& fit_options) {
  const tool::FitOptions options = Resolved(fit_options);
  lib::FitResult fit;
  double import_seconds = 0.0;
  {
    py::gil_scoped_release release;
    auto loaded = tool::LoadCharacter(path ? path->value : std::string(), options.parts_file);
    if (!loaded.ok()) Throw(loaded.error());
    import_seconds = loaded->import_seconds;
    auto result = lib::FitSpheres(loaded->character, loaded->parts, options.settings);
    if (!result.ok()) Throw(result.error());
    fit = std::move(result).value();
  }
  py::dict report;
  report["seconds"] = fit.report.seconds;
  report["import_seconds"] = import_seconds;
  report["body_height"] = fit.report.body_height;
  report["standoff_before"] = fit.report.standoff_before;
  report["standoff_after"] = fit.report.standoff_after;
  report["spheres_split"] = fit.report.spheres_split;
  report["split_rounds"] = fit.report.split_rounds;
  report["triangles_covered"] = fit.report.triangles_covered;
  return {std::make_shared<const runtime::SphereSet>(std::move(fit.spheres)), report};
}

// ---- Asset and Instance ----

struct PyAsset {
  std::shared_ptr<const runtime::CharacterAsset> asset;
};

PyAsset MakeAsset(const PySphereSet& set, float margin, float touch_tolerance) {
  runtime::NarrowPhaseSettings narrow;
  narrow.margin = margin;
  narrow.touch_tolerance_share = touch_tolerance;
  runtime::SphereSet copy = *set.set;
  py::gil_scoped_release release;
  return {Take(runtime::CharacterAsset::Create(std::move(copy), narrow))};
}

class PyInstance {
 public:
  PyInstance(const PyAsset& asset, const std::optional<std::vector<std::string>>& joint_names) : asset_(asset.asset) {
    if (joint_names) {
      mapping_ = Take(runtime::MapJoints(asset_->sphere_set(), *joint_names));
      instance_.emplace(Take(runtime::CharacterInstance::Create(asset_, mapping_)));
    } else {
      instance_.emplace(Take(runtime::CharacterInstance::Create(asset_)));
    }
    world_.resize(instance_->joint_input_count());
  }

  PyAsset asset() const { return {asset_}; }
  size_t joint_count() const { return instance_->joint_input_count(); }
  const runtime::JointMapping& mapping() const { return mapping_; }

  void UpdateFast(const py::handle& world) {
    Busy busy(this);
    ReadMatrices(world, "world", &world_);
    Check(Released([&] { return instance_->UpdateFast(world_); }));
  }

  void UpdateExact(const py::handle& positions, const py::handle& world) {
    Busy busy(this);
    ReadPositions(positions);
    std::span<const Mat4f> joints;
    if (!world.is_none()) {
      ReadMatrices(world, "world", &world_);
      joints = world_;
    }
    Check(Released([&] { return instance_->UpdateExact(positions_, joints); }));
  }

  py::array SpherePairs() {
    Busy busy(this);
    std::span<const runtime::SpherePair> pairs;
    {
      py::gil_scoped_release release;
      pairs = instance_->FindSpherePairs();
    }
    Check(instance_->status());
    return SpherePairArray(pairs);
  }

  py::tuple Contacts(const py::handle& positions) {
    Busy busy(this);
    std::span<const Eigen::Vector3f> skinned;
    if (!positions.is_none()) {
      ReadPositions(positions);
      skinned = positions_;
    }
    Check(Released([&] { return instance_->FindContacts(skinned); }));
    return ContactArrays(instance_->contacts());
  }

  // The per-frame loop of a C++ engine on these frames (update_fast, sphere pairs, contacts when
  // asked), with no Python between frames: what bench/python_overhead.py sets the Python loop
  // against. Returns seconds per frame (the matrices are read before the clock starts).
  double CppFrameLoop(const py::handle& worlds, bool contacts, int repeats) {
    Busy busy(this);
    const FloatArray a = ReadFloatArray(worlds, "worlds", {-1, -1, 4, 4});
    const size_t frames = static_cast<size_t>(a.shape[0]), joints = instance_->joint_input_count();
    if (frames == 0 || static_cast<size_t>(a.shape[1]) < joints || repeats < 1) {
      ThrowArgument("worlds: (F >= 1, J >= joint_count, 4, 4) and repeats >= 1");
    }
    std::vector<Mat4f> all(frames * joints);
    for (size_t f = 0; f < frames; ++f) {
      for (size_t j = 0; j < joints; ++j) {
        for (int r = 0; r < 4; ++r) {
          for (int c = 0; c < 4; ++c) {
            all[f * joints + j](r, c) = a.At({static_cast<py::ssize_t>(f), static_cast<py::ssize_t>(j), r, c});
          }
        }
      }
    }
    py::gil_scoped_release release;
    size_t checksum = 0;
    const auto start = std::chrono::steady_clock::now();
    for (int rep = 0; rep < repeats; ++rep) {
      for (size_t f = 0; f < frames; ++f) {
        Check(instance_->UpdateFast(std::span<const Mat4f>(all.data() + f * joints, joints)));
        checksum += instance_->FindSpherePairs().size();
        if (contacts) {
          Check(instance_->FindContacts());
          checksum += instance_->contacts().triangle_pairs.size();
        }
      }
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (checksum == static_cast<size_t>(-1)) std::abort();  // keeps the loop's results alive
    return seconds / (static_cast<double>(frames) * repeats);
  }

  py::array Spheres() {
    Busy busy(this);
    const auto spheres = instance_->spheres();
    if (!instance_->spheres_valid()) Check(instance_->status());
    py::array_t<float> out({static_cast<py::ssize_t>(spheres.size()), py::ssize_t{4}});
    if (!spheres.empty()) std::memcpy(out.mutable_data(), spheres.data(), spheres.size() * sizeof(Vec4f));
    return out;
  }

 private:
  // One thread at a time: a second one raises instead of racing.
  struct Busy {
    explicit Busy(PyInstance* self) : self_(self) {
      if (self_->busy_.exchange(true)) {
        throw py::value_error("skinspheres.Instance: used by two threads at once (one instance per thread)");
      }
    }
    ~Busy() { self_->busy_.store(false); }
    Busy(const Busy&) = delete;
    Busy& operator=(const Busy&) = delete;
    PyInstance* self_;
  };

  template <typename F>
  runtime::FrameStatus Released(F&& f) {
    py::gil_scoped_release release;
    return f();
  }
  static void Check(const runtime::FrameStatus& status) {
    if (!status.ok()) Throw(Error{status.code, status.message ? status.message : ToString(status.code)});
  }

  void ReadMatrices(const py::handle& object, const char* what, std::vector<Mat4f>* out) const {
    const FloatArray a = ReadFloatArray(object, what, {-1, 4, 4});
    const size_t need = instance_->joint_input_count();
    if (static_cast<size_t>(a.shape[0]) < need) {
      ThrowArgument(std::string(what) + ": " + std::to_string(a.shape[0]) + " matrices, the instance reads " +
                    std::to_string(need));
    }
    out->resize(need);
    for (size_t j = 0; j < need; ++j) {
      Mat4f& m = (*out)[j];
      for (int r = 0; r < 4; ++r) {
        for (int c = 0; c < 4; ++c) m(r, c) = a.At({static_cast<py::ssize_t>(j), r, c});
      }
    }
  }

  void ReadPositions(const py::handle& object) {
    const FloatArray a = ReadFloatArray(object, "positions", {-1, 3});
    const size_t need = asset_->source_vertex_count();
    if (static_cast<size_t>(a.shape[0]) < need) {
      ThrowArgument("positions: " + std::to_string(a.shape[0]) + " vertices, the set was fitted on " +
                    std::to_string(need));
    }
    positions_.resize(need);
    for (size_t v = 0; v < need; ++v) {
      for (int c = 0; c < 3; ++c) positions_[v][c] = a.At({static_cast<py::ssize_t>(v), c});
    }
  }

  std::shared_ptr<const runtime::CharacterAsset> asset_;
  runtime::JointMapping mapping_;
  std::optional<runtime::CharacterInstance> instance_;
  std::vector<Mat4f> world_;
  std::vector<Eigen::Vector3f> positions_;
  std::atomic<bool> busy_{false};
};

// ---- play ----

struct PlayArgs {
  std::string clip = "0";
  std::vector<std::string> clip_files;
  std::optional<std::string> spheres;
  std::string joint_map, source_rest, retarget = "auto";
  float fps = 30.0f, margin = 0.0f, touch_tolerance = tool::kDefaultTouchTolerance;
  int frames = 0;
  std::string mode = "exact";
};

// What play() returns: per-frame arrays with a `frame` field, built from the frame sink's calls.
struct PlayCollect {
  std::vector<float> times, clip_times;
  std::vector<FrameSpherePairRecord> sphere_pairs;
  std::vector<FramePartContactRecord> parts;
  std::vector<FrameTriangleContactRecord> triangles;
};

// With a clip file, `clip` counts or names the file's clips (appended after the character's own
// `own` clips, renamed "<file stem>/<name>" where the name was taken).
size_t FileClip(const lib::RawCharacter& character, size_t own, const std::string& file, const std::string& clip) {
  const size_t added = character.clips.size() - own;
  if (!clip.empty() && clip.find_first_not_of("0123456789") == std::string::npos) {
    const size_t k = clip.size() < 10 ? std::stoul(clip) : added;
    if (k < added) return own + k;
  }
  std::string names;
  for (size_t k = own; k < character.clips.size(); ++k) {
    const std::string& name = character.clips[k].name;
    if (name == clip || (name.size() > clip.size() && name.ends_with("/" + clip))) return k;
    names += (names.empty() ? "" : ", ") + std::to_string(k - own) + ":" + name;
  }
  Throw(Error{ErrorCode::kNotFound, file + ": no clip \"" + clip + "\"; clips: " + names});
}

// The clips a file holds, by name (an animation-only file too).
std::vector<std::string> ClipNames(const PathText& path_arg) {
  const std::string& path = path_arg.value;
  std::vector<std::string> names;
  py::gil_scoped_release release;
  auto file = lib::ReadAnimationFile(path);
  if (!file.ok()) Throw(file.error());
  for (const auto& clip : file->clips) names.push_back(clip.name);
  return names;
}

py::dict Play(const std::optional<std::string>& character, const PlayArgs& a) {
  if (a.mode != "exact" && a.mode != "fast") ThrowArgument("mode must be 'exact' or 'fast' (got '" + a.mode + "')");
  if (!(a.fps > 0.0f) || a.fps > 10000.0f) ThrowArgument("fps must be in (0, 10000]");
  if (a.frames < 0) ThrowArgument("frames must be >= 0 (0: the whole clip)");
  if (auto why = tool::CheckTouchTolerance(a.touch_tolerance)) ThrowArgument(*why);
  const tool::FitOptions fit_options = Resolved(tool::FitOptions{});  // as `play` fits on the fly
  PlayCollect got;
  std::string clip_name;
  std::vector<std::string> notes, part_names;
  float body_height = 0.0f, tolerance = 0.0f;
  int frame_count = 0;
  {
    py::gil_scoped_release release;
    auto loaded = tool::LoadCharacter(character.value_or(""), fit_options.parts_file);
    if (!loaded.ok()) Throw(loaded.error());
    tool::ClipFileOptions files;
    files.files = a.clip_files;
    files.joint_map = a.joint_map;
    files.source_rest = a.source_rest;
    files.retarget = a.retarget;
    const size_t own_clips = loaded->character.clips.size();
    if (auto why = tool::AddClipFiles(*loaded, files, a.fps, &notes)) Throw(*why);
    runtime::SphereSet set;
    if (a.spheres) {
      set = Take(runtime::LoadSphereSet(*a.spheres));
      tool::AttachMesh(loaded->character, &set);
    } else {
      set = Take(lib::FitSpheres(loaded->character, loaded->parts, fit_options.settings)).spheres;
    }
    const size_t clip = a.clip_files.empty() ? Take(tool::FindClip(loaded->character, a.clip))
                                             : FileClip(loaded->character, own_clips, a.clip_files.front(), a.clip);
    clip_name = loaded->character.clips[clip].name;
    tool::PlayOptions options;
    options.fps = a.fps;
    options.frames = a.frames;
    options.fast = a.mode == "fast";
    options.margin = a.margin;
    options.touch_tolerance = a.touch_tolerance;
    auto result = tool::PlayClip(*loaded, set, clip, options, [&](const tool::FrameView& f) {
      const auto frame = static_cast<uint32_t>(f.index);
      got.times.push_back(f.time_s);
      got.clip_times.push_back(f.clip_time_s);
      for (const auto& p : f.sphere_pairs) {
        got.sphere_pairs.push_back(WithFrame<FrameSpherePairRecord>(frame, ToRecord(p)));
      }
      const size_t first_part = got.parts.size(), first_triangle = got.triangles.size();
      for (size_t k = 0; k < f.contacts->parts.size(); ++k) {
        const runtime::PartContact& pc = f.contacts->parts[k];
        PartContactRecord r = ToRecord(pc);
        r.first_triangle = static_cast<uint32_t>(first_triangle + pc.first_triangle_pair);
        got.parts.push_back(WithFrame<FramePartContactRecord>(frame, r));
        for (uint32_t q = pc.first_triangle_pair; q < pc.first_triangle_pair + pc.triangle_pair_count; ++q) {
          got.triangles.push_back(WithFrame<FrameTriangleContactRecord>(
              frame, ToRecord(f.contacts->triangle_pairs[q], static_cast<uint32_t>(first_part + k))));
        }
      }
      body_height = f.body_height;
      tolerance = f.touch_tolerance;
    });
    if (!result.ok()) Throw(result.error());
    frame_count = result->frames;
    part_names = PartNames(set);
  }
  py::dict out;
  out["clip"] = Text(clip_name);
  out["frames"] = frame_count;
  out["times"] = CopyArray(got.times);
  out["clip_times"] = CopyArray(got.clip_times);
  out["sphere_pairs"] = CopyArray(got.sphere_pairs);
  out["part_contacts"] = CopyArray(got.parts);
  out["triangle_contacts"] = CopyArray(got.triangles);
  out["part_names"] = Texts(part_names);
  out["body_height"] = body_height;
  out["touch_tolerance"] = tolerance;
  out["notes"] = Texts(notes);
  return out;
}

// ---- check ----

py::dict Check(const std::string& character, const std::vector<std::string>& clip_files, const std::string& clip,
               float max_depth, float touch_tolerance, const std::optional<std::string>& spheres, float fps,
               const std::string& mode, int jobs, const std::string& joint_map, const std::string& source_rest,
               const std::string& retarget, bool compare_source) {
  tool::CheckArgs a;
  a.input = character;
  a.clip_files.files = clip_files;
  a.clip_files.joint_map = joint_map;
  a.clip_files.source_rest = source_rest;
  a.clip_files.retarget = retarget;
  a.clip = clip;
  a.max_depth = max_depth;
  a.touch_tolerance = touch_tolerance;
  a.spheres = spheres.value_or("");
  a.fps = fps;
  a.mode = mode;
  a.jobs = jobs;
  a.compare_source = compare_source;
  tool::CheckOutcome outcome;
  {
    py::gil_scoped_release release;
    outcome = tool::RunCheck(a, /*quiet=*/true);
  }
  if (outcome.report.is_null()) Throw(Error{outcome.error_code, outcome.error});
  py::dict report = py::module_::import("json").attr("loads")(
      outcome.report.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
  report["exit_code"] = outcome.exit_code;
  return report;
}

PySphereSet SetOf(const PyAsset& a) {
  // Shares the asset's own set (aliasing: the asset stays alive while the set object does).
  return {std::shared_ptr<const runtime::SphereSet>(a.asset, &a.asset->sphere_set()), {}};
}

py::object g_contacts_type;  // collections.namedtuple("Contacts", "parts triangles")

}  // namespace
}  // namespace skinspheres::python

using namespace skinspheres;          // NOLINT(google-build-using-namespace): the module's definitions
using namespace skinspheres::python;  // NOLINT(google-build-using-namespace)
using namespace pybind11::literals;   // NOLINT(google-build-using-namespace)

PYBIND11_MODULE(_skinspheres, m) {
  m.doc() = "skinspheres: sphere sets for skinned characters and their self-contacts (native part).";
  m.attr("__version__") = SKINSPHERES_VERSION_STRING;
  RegisterErrors(m);

  PYBIND11_NUMPY_DTYPE(SpherePairRecord, i, j, depth, part_i, part_j);
  PYBIND11_NUMPY_DTYPE(PartContactRecord, part_a, part_b, kind, depth, min_distance, normal, center, triangle_pairs,
                       intersecting, sphere_pairs, first_triangle);
  PYBIND11_NUMPY_DTYPE(TriangleContactRecord, part_contact, triangle_a, triangle_b, kind, distance, point, on_a, on_b);
  PYBIND11_NUMPY_DTYPE(FrameSpherePairRecord, frame, i, j, depth, part_i, part_j);
  PYBIND11_NUMPY_DTYPE(FramePartContactRecord, frame, part_a, part_b, kind, depth, min_distance, normal, center,
                       triangle_pairs, intersecting, sphere_pairs, first_triangle);
  PYBIND11_NUMPY_DTYPE(FrameTriangleContactRecord, frame, part_contact, triangle_a, triangle_b, kind, distance, point,
                       on_a, on_b);
  m.attr("SPHERE_PAIR_DTYPE") = py::dtype::of<SpherePairRecord>();
  m.attr("PART_CONTACT_DTYPE") = py::dtype::of<PartContactRecord>();
  m.attr("TRIANGLE_CONTACT_DTYPE") = py::dtype::of<TriangleContactRecord>();
  m.attr("FRAME_SPHERE_PAIR_DTYPE") = py::dtype::of<FrameSpherePairRecord>();
  m.attr("FRAME_PART_CONTACT_DTYPE") = py::dtype::of<FramePartContactRecord>();
  m.attr("FRAME_TRIANGLE_CONTACT_DTYPE") = py::dtype::of<FrameTriangleContactRecord>();
  m.attr("TOUCHING") = 0;
  m.attr("PENETRATING") = 1;
  m.attr("INTERSECTING") = 0;
  m.attr("WITHIN_MARGIN") = 1;
  m.attr("DEFAULT_TOUCH_TOLERANCE") = tool::kDefaultTouchTolerance;
  g_masked_array_type = py::module_::import("numpy.ma").attr("MaskedArray");
  g_contacts_type = py::module_::import("collections").attr("namedtuple")("Contacts", "parts triangles");
  g_contacts_type.attr("__module__") = "skinspheres";
  m.attr("Contacts") = g_contacts_type;
  // The namedtuple outlives the interpreter's last reference only through this capsule.
  m.add_object("_cleanup", py::capsule([] {
                 g_contacts_type.release();
                 g_masked_array_type.release();
               }));

  py::class_<PySphereSet>(m, "SphereSet", "A fitted sphere set: spheres in the rest pose, their parts and joints.")
      .def("__len__", [](const PySphereSet& s) { return s.set->size(); })
      .def("__repr__",
           [](const PySphereSet& s) {
             return "<skinspheres.SphereSet " + std::to_string(s.set->size()) + " spheres, " +
                    std::to_string(s.set->parts.size()) + " parts, " + std::to_string(s.set->joint_count()) +
                    " joints, fitted on '" + std::string(py::str(Text(s.set->source_file))) + "'>";
           })
      .def(
          "save",
          [](const PySphereSet& s, const PathText& path, bool fast_only) {
            std::optional<std::string> why;
            {
              py::gil_scoped_release release;
              why = tool::SaveSetFile(*s.set, path.value, fast_only);
            }
            if (why) ThrowArgument(*why);
          },
          "path"_a, py::kw_only(), "fast_only"_a = false)
      .def_property_readonly("centers", [](const PySphereSet& s) { return Vec3Array(s.set->centers_rest); })
      .def_property_readonly("radii", [](const PySphereSet& s) { return CopyArray(s.set->radii_rest); })
      .def_property_readonly("radii_fast", [](const PySphereSet& s) { return CopyArray(s.set->radii_fast); })
      .def_property_readonly("sphere_part", [](const PySphereSet& s) { return CopyArray(s.set->sphere_part); })
      .def_property_readonly("sphere_joint", [](const PySphereSet& s) { return CopyArray(s.set->sphere_joint); })
      .def(
          "sphere_joints",
          [](const PySphereSet& s, size_t sphere) {
            const runtime::SphereSet& set = *s.set;
            if (sphere >= set.size() || set.influence_offsets.size() != set.size() + 1) {
              ThrowArgument("sphere " + std::to_string(sphere) + " out of range (" + std::to_string(set.size()) +
                            " spheres)");
            }
            const uint32_t a = set.influence_offsets[sphere], b = set.influence_offsets[sphere + 1];
            std::vector<uint16_t> joints(set.influence_joints.begin() + a, set.influence_joints.begin() + b);
            std::vector<float> weights(set.influence_weights.begin() + a, set.influence_weights.begin() + b);
            return py::make_tuple(CopyArray(joints), CopyArray(weights));
          },
          "sphere"_a)
      .def_property_readonly("part_names", [](const PySphereSet& s) { return Texts(PartNames(*s.set)); })
      .def_property_readonly("joint_names", [](const PySphereSet& s) { return Texts(s.set->joint_names); })
      .def_property_readonly("joint_parents", [](const PySphereSet& s) { return CopyArray(s.set->joint_parents); })
      .def_property_readonly("joint_rest_world",
                             [](const PySphereSet& s) { return MatrixArray(s.set->joint_rest_world); })
      .def_property_readonly(
          "excluded_pairs",
          [](const PySphereSet& s) {
            py::array_t<uint32_t> out({static_cast<py::ssize_t>(s.set->excluded_pairs.size()), py::ssize_t{2}});
            auto m2 = out.mutable_unchecked<2>();
            for (size_t k = 0; k < s.set->excluded_pairs.size(); ++k) {
              m2(static_cast<py::ssize_t>(k), 0) = s.set->excluded_pairs[k].i;
              m2(static_cast<py::ssize_t>(k), 1) = s.set->excluded_pairs[k].j;
            }
            return out;
          })
      .def_property_readonly("excluded_reasons",
                             [](const PySphereSet& s) {
                               std::vector<std::string> reasons;
                               for (const auto& e : s.set->excluded_pairs) reasons.emplace_back(ToString(e.reason));
                               return reasons;
                             })
      .def_property_readonly("contact_rules", [](const PySphereSet& s) { return ToString(s.set->contact_rules); })
      .def_property_readonly("contact_hops", [](const PySphereSet& s) { return s.set->contact_hops; })
      .def_property_readonly("rest_gap", [](const PySphereSet& s) { return s.set->rest_gap; })
      .def_property_readonly("vertex_count", [](const PySphereSet& s) { return s.set->source_vertex_count; })
      .def_property_readonly("triangle_count", [](const PySphereSet& s) { return s.set->source_triangle_count; })
      .def_property_readonly("has_mesh", [](const PySphereSet& s) { return s.set->has_mesh(); })
      .def_property_readonly("fast_only", [](const PySphereSet& s) { return s.set->fast_only; })
      .def_property_readonly("source_file", [](const PySphereSet& s) { return Text(s.set->source_file); })
      .def_property_readonly("loaded_from", [](const PySphereSet& s) { return Text(s.set->loaded_from); })
      .def_property_readonly("fit_report", [](const PySphereSet& s) { return py::dict(s.fit_report.attr("copy")()); })
      .def_property_readonly("triangles",
                             [](const PySphereSet& s) {
                               const auto& tv = s.set->triangle_vertices;
                               py::array_t<uint32_t> out({static_cast<py::ssize_t>(tv.size() / 3), py::ssize_t{3}});
                               if (!tv.empty())
                                 std::memcpy(out.mutable_data(), tv.data(), tv.size() * sizeof(uint32_t));
                               return out;
                             })
      .def_property_readonly("mesh", [](const PySphereSet& s) {
        const skinning::SkinnedMesh& mesh = s.set->mesh;
        std::vector<int32_t> joints;
        std::vector<Mat4f> inverse_binds;
        for (const auto& b : mesh.binds) {
          joints.push_back(b.joint);
          inverse_binds.push_back(b.inverse_bind);
        }
        py::dict d;
        d["positions_bind"] = Vec3Array(mesh.positions_bind);
        d["bind_joints"] = CopyArray(joints);
        d["inverse_binds"] = MatrixArray(inverse_binds);
        d["influence_offsets"] = CopyArray(mesh.influence_offsets);
        d["influence_binds"] = CopyArray(mesh.influence_binds);
        d["influence_weights"] = CopyArray(mesh.influence_weights);
        return d;
      });

  py::class_<PyAsset>(m, "Asset", "A sphere set made ready for the runtime: immutable, shared by its instances.")
      .def(py::init(&MakeAsset), "sphere_set"_a, py::kw_only(), "margin"_a = 0.0f,
           "touch_tolerance"_a = tool::kDefaultTouchTolerance)
      .def(
          "instance",
          [](const PyAsset& a, const std::optional<std::vector<std::string>>& joint_names) {
            return std::make_unique<PyInstance>(a, joint_names);
          },
          "joint_names"_a = py::none())
      .def(
          "check",
          [](const PyAsset& a, const std::vector<std::string>& joint_names, size_t vertex_count) {
            if (auto e = a.asset->Matches(joint_names, vertex_count)) Throw(*e);
          },
          "joint_names"_a, "vertex_count"_a)
      .def_property_readonly("sphere_set", &SetOf)
      .def_property_readonly("part_names", [](const PyAsset& a) { return Texts(PartNames(a.asset->sphere_set())); })
      .def_property_readonly("joint_names", [](const PyAsset& a) { return Texts(a.asset->sphere_set().joint_names); })
      .def_property_readonly("joints_read",
                             [](const PyAsset& a) {
                               const std::vector<bool> read = runtime::JointsReadPerFrame(a.asset->sphere_set());
                               py::array_t<bool> out(static_cast<py::ssize_t>(read.size()));
                               for (size_t k = 0; k < read.size(); ++k) out.mutable_data()[k] = read[k];
                               return out;
                             })
      .def_property_readonly("sphere_count", [](const PyAsset& a) { return a.asset->size(); })
      .def_property_readonly("vertex_count", [](const PyAsset& a) { return a.asset->source_vertex_count(); })
      .def_property_readonly("has_contacts", [](const PyAsset& a) { return a.asset->narrow_phase() != nullptr; })
      .def_property_readonly(
          "margin",
          [](const PyAsset& a) { return a.asset->narrow_phase() ? a.asset->narrow_phase()->settings().margin : 0.0f; })
      .def_property_readonly("touch_tolerance", [](const PyAsset& a) {
        return a.asset->narrow_phase() ? a.asset->narrow_phase()->touch_tolerance() : 0.0f;
      });

  py::class_<PyInstance>(m, "Instance", "One character's per-frame state; one thread at a time.")
      .def(py::init<const PyAsset&, const std::optional<std::vector<std::string>>&>(), "asset"_a,
           "joint_names"_a = py::none())
      .def("update_fast", &PyInstance::UpdateFast, "world"_a)
      .def("update_exact", &PyInstance::UpdateExact, "positions"_a, "world"_a = py::none())
      .def("sphere_pairs", &PyInstance::SpherePairs)
      .def(
          "contacts",
          [](PyInstance& self, const py::handle& positions) {
            py::tuple t = self.Contacts(positions);
            return g_contacts_type(t[0], t[1]);
          },
          "positions"_a = py::none())
      .def("_cpp_frame_loop", &PyInstance::CppFrameLoop, "worlds"_a, "contacts"_a = true, "repeats"_a = 1)
      .def_property_readonly("spheres", &PyInstance::Spheres)
      .def_property_readonly("asset", &PyInstance::asset)
      .def_property_readonly("joint_count", &PyInstance::joint_count)
      .def_property_readonly("extra_joints", [](const PyInstance& i) { return Texts(i.mapping().extra_engine_joints); })
      .def_property_readonly("unmapped_joints",
                             [](const PyInstance& i) { return Texts(i.mapping().unmapped_set_joints); });

  const tool::FitOptions d;  // the tool's defaults
  m.def(
      "fit",
      [](const std::optional<PathText>& path, const std::string& parts, int rays, int per_level,
         const std::string& method, float overlap, float step, int hops, int refine, bool tighten, float split_gain,
         int split_rounds, float target_standoff, int max_spheres, float rest_gap, float piece_edge,
         bool group_blends) {
        NoNul(parts, "parts");
        tool::FitOptions o;  // what the tool's options of the same names set
        o.parts_file = parts;
        o.settings.rays = rays;
        o.settings.per_level = per_level;
        o.method = method;
        o.settings.overlap = overlap;
        o.settings.step = step;
        o.settings.contact_hops = hops;
        o.settings.refine_iterations = refine;
        o.no_tighten = !tighten;
        o.settings.split_gain = split_gain;
        o.settings.split_rounds = split_rounds;
        o.settings.target_standoff = target_standoff;
        o.settings.max_spheres = max_spheres;
        o.settings.rest_gap = rest_gap;
        o.settings.piece_edge = piece_edge;
        o.no_group_blends = !group_blends;
        return Fit(path, o);
      },
      "path"_a = py::none(), py::kw_only(), "parts"_a = d.parts_file, "rays"_a = d.settings.rays,
      "per_level"_a = d.settings.per_level, "method"_a = d.method, "overlap"_a = d.settings.overlap,
      "step"_a = d.settings.step, "hops"_a = d.settings.contact_hops, "refine"_a = d.settings.refine_iterations,
      "tighten"_a = !d.no_tighten, "split_gain"_a = d.settings.split_gain, "split_rounds"_a = d.settings.split_rounds,
      "target_standoff"_a = d.settings.target_standoff, "max_spheres"_a = d.settings.max_spheres,
      "rest_gap"_a = d.settings.rest_gap, "piece_edge"_a = d.settings.piece_edge,
      "group_blends"_a = !d.no_group_blends);
  m.def("load", &Load, "path"_a);
  m.def(
      "clip_names", [](const PathText& path) { return Texts(ClipNames(path)); }, "path"_a);
  m.def(
      "play",
      [](const std::optional<PathText>& character, const std::optional<PathText>& clip_file,
         const std::variant<int64_t, std::string>& clip, float fps, const std::string& mode, int64_t frames,
         const std::optional<PathText>& spheres, float margin, float touch_tolerance, const std::string& joint_map,
         const std::string& source_rest, const std::string& retarget) {
        PlayArgs a;
        if (clip_file) a.clip_files.push_back(clip_file->value);
        if (const int64_t* index = std::get_if<int64_t>(&clip)) {
          if (*index < 0) ThrowArgument("clip: " + std::to_string(*index) + " (an index counts from 0)");
          a.clip = std::to_string(*index);
        } else {
          a.clip = std::get<std::string>(clip);
        }
        if (frames < 0 || frames > kMaxPlayFrames) {
          ThrowArgument("frames: " + std::to_string(frames) + " (0: the whole clip; at most " +
                        std::to_string(kMaxPlayFrames) + ")");
        }
        NoNul(joint_map, "joint_map");
        NoNul(source_rest, "source_rest");
        a.fps = fps;
        a.mode = mode;
        a.frames = static_cast<int>(frames);
        if (spheres) a.spheres = spheres->value;
        a.margin = margin;
        a.touch_tolerance = touch_tolerance;
        a.joint_map = joint_map;
        a.source_rest = source_rest;
        a.retarget = retarget;
        return Play(character ? std::optional<std::string>(character->value) : std::nullopt, a);
      },
      "character"_a = py::none(), "clip_file"_a = py::none(), py::kw_only(), "clip"_a = int64_t{0}, "fps"_a = 30.0f,
      "mode"_a = "exact", "frames"_a = 0, "spheres"_a = py::none(), "margin"_a = 0.0f,
      "touch_tolerance"_a = tool::kDefaultTouchTolerance, "joint_map"_a = "", "source_rest"_a = "",
      "retarget"_a = "auto");
  m.def(
      "check",
      [](const PathText& character, const std::vector<PathText>& clip_files, const std::string& clip, float max_depth,
         float touch_tolerance, const std::optional<PathText>& spheres, float fps, const std::string& mode, int jobs,
         const std::string& joint_map, const std::string& source_rest, const std::string& retarget,
         bool compare_source) {
        std::vector<std::string> files;
        for (const PathText& f : clip_files) files.push_back(f.value);
        NoNul(joint_map, "joint_map");
        NoNul(source_rest, "source_rest");
        return Check(character.value, files, clip, max_depth, touch_tolerance,
                     spheres ? std::optional<std::string>(spheres->value) : std::nullopt, fps, mode, jobs, joint_map,
                     source_rest, retarget, compare_source);
      },
      "character"_a, "clip_files"_a = std::vector<PathText>{}, py::kw_only(), "clip"_a = "all",
      "max_depth"_a = tool::kDefaultMaxDepth, "touch_tolerance"_a = tool::kDefaultTouchTolerance,
      "spheres"_a = py::none(), "fps"_a = 30.0f, "mode"_a = "exact", "jobs"_a = 0, "joint_map"_a = "",
      "source_rest"_a = "", "retarget"_a = "auto", "compare_source"_a = false);
}
