// The module's array input and output (module_internal.h): numpy arrays of any float layout read
// into the library's types, and the library's results as structured numpy arrays.
#include "module_internal.h"

namespace skinspheres::python {

py::object g_masked_array_type;

namespace {

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

}  // namespace

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

SpherePairRecord ToRecord(const runtime::SpherePair& p) {
  return {p.sphere_i, p.sphere_j, p.depth, p.part_i, p.part_j};
}

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
  r.first_triangle_pair = p.first_triangle_pair;
  return r;
}

TriangleContactRecord ToRecord(const runtime::TriangleContact& c, uint32_t part_contact) {
  TriangleContactRecord r{};
  r.part_contact = part_contact;
  r.triangle_a = c.triangle_a;
  r.triangle_b = c.triangle_b;
  r.kind = static_cast<uint32_t>(c.kind);
  r.distance = c.distance;
  std::memcpy(r.point, c.point, sizeof r.point);
  std::memcpy(r.on_a, c.on_a, sizeof r.on_a);
  std::memcpy(r.on_b, c.on_b, sizeof r.on_b);
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

}  // namespace skinspheres::python
