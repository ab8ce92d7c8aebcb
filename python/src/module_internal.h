// What the native module's files share (module.cc binds them): path arguments, errors, array
// input and output, and the types the bindings wrap. Internal to the Python module.
#pragma once

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
#include "colliders.h"
#include "commands.h"
#include "fix.h"
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

// ---- Errors (errors.cc) ----

struct LibraryError {
  ErrorCode code;
  std::string message;
};

// A library error as the matching Python exception (RegisterErrors), its message on one line.
[[noreturn]] void Throw(const Error& e);
[[noreturn]] void ThrowArgument(const std::string& message);

// A file name given as text (a joint map, a rest rig, a parts file): the C++ side would cut it at a
// NUL byte and read another file.
void NoNul(const std::string& text, const char* what);

// play(frames=...): at most this many (a day at 30 fps would be 2.6 million; the per-frame arrays
// grow with it, and the call cannot be interrupted while it runs).
inline constexpr int64_t kMaxPlayFrames = 1000000;

template <typename T>
T Take(Result<T> r) {
  if (!r.ok()) Throw(r.error());
  return std::move(r).value();
}

// Text the library holds (names and paths from files) as str: invalid UTF-8 is replaced, never an
// exception on reading a property.
py::str Text(const std::string& text);
py::list Texts(const std::vector<std::string>& texts);

// skinspheres.Error and its subclasses, and the translator that raises them.
void RegisterErrors(py::module_& m);

// ---- Array input (arrays.cc) ----

// A float32 or float64 array of the given shape (-1: any length >= min_first on the first axis),
// any strides. TypeError for another dtype, InvalidArgument for another shape.
// At most 4 axes (the frame loop's (F, J, 4, 4)); fixed arrays, so reading a frame's input
// allocates nothing.
inline constexpr size_t kMaxAxes = 4;

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
extern py::object g_masked_array_type;

// `object` as a float32 or float64 array of shape `want` (-1: any length on that axis), any
// strides. TypeError for another type or dtype, InvalidArgument for another shape.
FloatArray ReadFloatArray(const py::handle& object, const char* what, std::initializer_list<py::ssize_t> want);

// ---- Array output (arrays.cc) ----

// The records of the structured arrays (dtypes registered in the module: no padding, so the
// numpy dtypes print as plain field lists). kind: PartContactKind, TriangleContactKind.
struct SpherePairRecord {
  uint32_t sphere_i, sphere_j;
  float depth;
  uint16_t part_i, part_j;
};
struct PartContactRecord {
  uint16_t part_a, part_b;
  uint32_t kind;  // 0 touching, 1 penetrating
  float depth, min_distance;
  float normal[3], center[3];
  uint32_t triangle_pairs, intersecting, sphere_pairs, first_triangle_pair;
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
  uint32_t sphere_i, sphere_j;
  float depth;
  uint16_t part_i, part_j;
};
struct FramePartContactRecord {
  uint32_t frame;
  uint16_t part_a, part_b;
  uint32_t kind;
  float depth, min_distance;
  float normal[3], center[3];
  uint32_t triangle_pairs, intersecting, sphere_pairs, first_triangle_pair;
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

template <typename T>
py::array CopyArray(const std::vector<T>& v) {
  auto out = NewArray<T>(v.size());
  if (!v.empty()) std::memcpy(out.mutable_data(), v.data(), v.size() * sizeof(T));
  return out;
}

SpherePairRecord ToRecord(const runtime::SpherePair& p);
PartContactRecord ToRecord(const runtime::PartContact& p);
TriangleContactRecord ToRecord(const runtime::TriangleContact& c, uint32_t part_contact);
py::array SpherePairArray(std::span<const runtime::SpherePair> pairs);
// A frame's contacts: (parts, triangles) structured arrays.
py::tuple ContactArrays(const runtime::FrameContacts& contacts);
py::array Vec3Array(const std::vector<Eigen::Vector3f>& v);  // (N, 3) float32
py::array MatrixArray(std::span<const Mat4f> v);             // (N, 4, 4) float32
std::vector<std::string> PartNames(const runtime::SphereSet& set);

// ---- Sphere sets, assets and instances (instance.cc) ----

struct PySphereSet {
  std::shared_ptr<const runtime::SphereSet> set;
  py::dict fit_report;  // empty unless made by fit()
};

// A sphere set file (JSON or binary), read with the GIL released.
PySphereSet Load(const PathText& path_arg);

// The fit options as the tool resolves them (method name, hops, flags); InvalidArgument when refused.
tool::FitOptions Resolved(tool::FitOptions options);

// The fitter on a character file (or the built-in character), with its report.
PySphereSet Fit(const std::optional<PathText>& path, const tool::FitOptions& fit_options);

struct PyAsset {
  std::shared_ptr<const runtime::CharacterAsset> asset;
};

PyAsset MakeAsset(const PySphereSet& set, float margin, float touch_tolerance);

// runtime::PoseFixer on one pose: locals (J, 10) float32/float64, per joint of the set translation
// xyz, rotation quaternion xyzw, scale xyz. Returns (the fixed pose as a new (J, 10) float32 array,
// {"holds", "steps", "deepest_before", "deepest_after"}).
py::tuple FixPose(const PyAsset& asset, const py::handle& locals, float max_depth);

// The asset's own set, shared (aliasing: the asset stays alive while the set object does).
PySphereSet SetOf(const PyAsset& a);

class PyInstance {
 public:
  PyInstance(const PyAsset& asset, const std::optional<std::vector<std::string>>& joint_names);

  PyAsset asset() const { return {asset_}; }
  size_t joint_count() const { return instance_->joint_input_count(); }
  const runtime::JointMapping& mapping() const { return mapping_; }

  void UpdateFast(const py::handle& world);
  void UpdateExact(const py::handle& positions, const py::handle& world);
  py::array SpherePairs();
  py::tuple Contacts(const py::handle& positions);

  // The per-frame loop of a C++ engine on these frames (update_fast, sphere pairs, contacts when
  // asked), with no Python between frames: what bench/python_overhead.py sets the Python loop
  // against. Returns seconds per frame (the matrices are read before the clock starts).
  double CppFrameLoop(const py::handle& worlds, bool contacts, int repeats);
  py::array Spheres();  // (N, 4): centre, radius

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
  static void Check(const runtime::FrameStatus& status);
  void ReadMatrices(const py::handle& object, const char* what, std::vector<Mat4f>* out) const;
  void ReadPositions(const py::handle& object);

  std::shared_ptr<const runtime::CharacterAsset> asset_;
  runtime::JointMapping mapping_;
  std::optional<runtime::CharacterInstance> instance_;
  std::vector<Mat4f> world_;
  std::vector<Eigen::Vector3f> positions_;
  std::atomic<bool> busy_{false};
};

// ---- play and check: the tool's own code (tools.cc) ----

struct PlayArgs {
  std::string clip = "0";
  std::vector<std::string> clip_files;
  std::optional<std::string> spheres;
  std::string joint_map, source_rest, retarget = "auto";
  float fps = 30.0f, margin = 0.0f, touch_tolerance = tool::kDefaultTouchTolerance;
  int frames = 0;
  std::string mode = "exact";
};

// The clips a file holds, by name (an animation-only file too).
std::vector<std::string> ClipNames(const PathText& path_arg);

// `skinspheres play` on one clip: per-frame arrays with a `frame` field, and the clip's figures.
py::dict Play(const std::optional<std::string>& character, const PlayArgs& a);

// The retarget options of play, check, retarget and fix as the tool takes them.
tool::ClipFileOptions ClipFiles(const std::vector<std::string>& files, const std::string& joint_map,
                                const std::string& source_rest, const std::string& retarget,
                                const std::string& rest_directions);

// `skinspheres retarget`: the written file's clips, durations, frames and notes.
py::dict Retarget(const std::string& character, const tool::ClipFileOptions& files, const std::string& output,
                  const std::string& clip, float fps);

// `skinspheres check`: its JSON report as a dict, with "exit_code".
py::dict Check(tool::CheckArgs a);

// `skinspheres fix`: its options past the files, as the binding takes them (keywords).
struct FixArgs {
  std::string clip = "all";
  std::vector<std::string> allow;
  float max_depth = tool::kDefaultTouchTolerance;
  std::optional<std::string> spheres;
  float fps = 30.0f, ease = 0.2f, max_rotation = 60.0f, max_jerk_ratio = 1.5f;
  int jobs = 0;
  std::string joint_map, source_rest, retarget = "auto";
};
// Its JSON report as a dict, with "exit_code"; the clips that hold are written to `output`.
py::dict Fix(const std::string& character, const std::vector<std::string>& clip_files, const std::string& output,
             const FixArgs& args);

// `skinspheres colliders`: its report as a dict with "exit_code", and the shapes as arrays: "joint"
// (N,) uint32, "head", "tail" (N, 3) float32 in each joint's rigid frame, "head_radius",
// "tail_radius" (N,), "part" (N names), "joint_names", "joint_rest_world" (J, 4, 4). Written to
// a.output in a.format when given.
py::dict Colliders(tool::CollidersArgs a);

}  // namespace skinspheres::python
