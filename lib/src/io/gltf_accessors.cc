// glTF 2.0 accessor reading (spec section 3.6.2: accessors, bufferViews, sparse accessors), typed
// and bounds-checked: every offset, stride and count is checked against the buffer it points into
// before a byte is read (the file is untrusted).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>

#include "gltf_document.h"
#include "skinspheres/lib/io/importer.h"

namespace skinspheres::lib::detail {
namespace {

using nlohmann::json;

int ComponentsOf(const std::string& type) {
  if (type == "SCALAR") return 1;
  if (type == "VEC2") return 2;
  if (type == "VEC3") return 3;
  if (type == "VEC4") return 4;
  if (type == "MAT2") return 4;
  if (type == "MAT3") return 9;
  if (type == "MAT4") return 16;
  return 0;
}

int ComponentSize(int component_type) {
  switch (component_type) {
    case 5120:
    case 5121: return 1;  // BYTE, UNSIGNED_BYTE
    case 5122:
    case 5123: return 2;  // SHORT, UNSIGNED_SHORT
    case 5125:
    case 5126: return 4;  // UNSIGNED_INT, FLOAT
    default: return 0;
  }
}

template <typename T>
T Load(const uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

// A validated view of one accessor: element e, component c is at base + e * stride + c * size.
// Dense accessors point straight into the document's buffers (zero copy); sparse accessors are
// materialised into `owned` (tightly packed) and `base` points into it, so a copy of the view
// keeps its bytes alive.
struct AccessorView {
  const uint8_t* base = nullptr;  // nullptr: no bufferView and not sparse, all zeros (glTF 3.6.2.3)
  uint64_t count = 0;
  uint64_t stride = 0;
  int components = 0;
  int component_type = 0;
  bool normalized = false;
  std::shared_ptr<const std::vector<uint8_t>> owned;  // the materialised sparse accessor, else empty
};

// An accessor may ask for this many elements without a bufferView (all zeros, or a sparse
// accessor's zero base): a 200-byte file must not allocate gigabytes.
constexpr uint64_t kMaxZeroFilledCount = uint64_t{1} << 20;

// The bytes of bufferView `bv_index` (checked to lie inside its buffer) and its byteStride (0
// when absent). Returns the problem, empty on success.
std::string OpenBufferView(const GltfDocument& doc, int64_t bv_index, std::span<const uint8_t>* bytes,
                           int64_t* stride) {
  const json& j = doc.json;
  if (!j.contains("bufferViews") || !j["bufferViews"].is_array() || bv_index < 0 ||
      bv_index >= static_cast<int64_t>(j["bufferViews"].size())) {
    return "bufferView " + std::to_string(bv_index) + " does not exist";
  }
  const json& bv = j["bufferViews"][static_cast<size_t>(bv_index)];
  const int64_t buffer = Integer(bv, "buffer", -1);
  if (buffer < 0 || buffer >= static_cast<int64_t>(doc.buffers.size())) {
    return "bufferView " + std::to_string(bv_index) + " uses buffer " + std::to_string(buffer) +
           ", which does not exist";
  }
  const std::vector<uint8_t>& data = doc.buffers[static_cast<size_t>(buffer)];
  const int64_t bv_offset = Integer(bv, "byteOffset", 0);
  const int64_t bv_length = Integer(bv, "byteLength", -1);
  *stride = Integer(bv, "byteStride", 0);
  if (bv_offset < 0 || bv_length < 0 || *stride < 0 || static_cast<uint64_t>(bv_offset) > data.size() ||
      static_cast<uint64_t>(bv_length) > data.size() - static_cast<uint64_t>(bv_offset)) {
    return "bufferView " + std::to_string(bv_index) + " lies outside its buffer (" + std::to_string(data.size()) +
           " bytes)";
  }
  *bytes = std::span<const uint8_t>(data.data() + bv_offset, static_cast<size_t>(bv_length));
  return {};
}

// One tightly packed array of a sparse block (`what` is "indices" or "values"): `count`
// elements of `elem_size` bytes at sparse.<what>.byteOffset in sparse.<what>.bufferView.
std::string OpenSparseArray(const GltfDocument& doc, const json& sparse, const std::string& name, const char* what,
                            uint64_t count, uint64_t elem_size, const uint8_t** out) {
  const std::string label = name + " sparse " + what;
  if (!sparse.contains(what) || !sparse[what].is_object()) return label + " is missing (or not an object)";
  const json& s = sparse[what];
  int64_t bv_index = -1, offset = 0;
  if (!s.contains("bufferView") || !IntField(s, "bufferView", -1, &bv_index)) {
    return label + " has no valid bufferView";
  }
  if (!IntField(s, "byteOffset", 0, &offset) || offset < 0) return label + " has an invalid byteOffset";
  std::span<const uint8_t> bytes;
  int64_t stride = 0;
  if (std::string p = OpenBufferView(doc, bv_index, &bytes, &stride); !p.empty()) return label + ": " + p;
  // glTF: these bufferViews MUST NOT define byteStride; one equal to the packed size is harmless.
  if (stride != 0 && static_cast<uint64_t>(stride) != elem_size) {
    return label + " bufferView " + std::to_string(bv_index) + " has a byteStride (sparse data must be tightly packed)";
  }
  // offset + count * elem_size <= length, by division so a huge count cannot wrap the product.
  const uint64_t avail = bytes.size(), off = static_cast<uint64_t>(offset);
  if (off > avail || count > (avail - off) / elem_size) {
    return label + " (" + std::to_string(count) + " elements at byteOffset " + std::to_string(off) +
           ") runs past the end of bufferView " + std::to_string(bv_index);
  }
  *out = bytes.data() + off;
  return {};
}

// glTF 3.6.2.3: copies the base elements (or zeros) into a tightly packed buffer and substitutes
// element indices[i] by values[i]. `view` is the validated dense part (base may be nullptr).
std::string MaterialiseSparse(const GltfDocument& doc, const json& a, const std::string& name, AccessorView* view) {
  const json& sparse = a["sparse"];
  if (!sparse.is_object()) return name + " has a sparse entry that is not an object";
  int64_t count = -1;
  if (!sparse.contains("count") || !IntField(sparse, "count", -1, &count))
    return name + " sparse block has no valid count";
  if (count < 1 || static_cast<uint64_t>(count) > view->count) {
    return name + " sparse count " + std::to_string(count) + " is not in 1.." + std::to_string(view->count) +
           " (the accessor's count)";
  }
  const uint64_t n = static_cast<uint64_t>(count);
  if (!sparse.contains("indices") || !sparse["indices"].is_object())
    return name + " sparse indices are missing (or not an object)";
  int64_t index_type = 0;
  if (!IntField(sparse["indices"], "componentType", 0, &index_type) ||
      (index_type != 5121 && index_type != 5123 && index_type != 5125)) {
    return name + " sparse indices have no valid componentType (UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT)";
  }
  const uint64_t index_size = static_cast<uint64_t>(ComponentSize(static_cast<int>(index_type)));
  const uint64_t elem_size =
      static_cast<uint64_t>(ComponentSize(view->component_type)) * static_cast<uint64_t>(view->components);
  const uint8_t* indices = nullptr;
  const uint8_t* values = nullptr;
  if (std::string p = OpenSparseArray(doc, sparse, name, "indices", n, index_size, &indices); !p.empty()) return p;
  if (std::string p = OpenSparseArray(doc, sparse, name, "values", n, elem_size, &values); !p.empty()) return p;

  // The dense base is bounded by the file (it lies in a bufferView) or by kMaxZeroFilledCount.
  auto owned = std::make_shared<std::vector<uint8_t>>(view->count * elem_size, uint8_t{0});
  if (view->base != nullptr) {
    for (uint64_t e = 0; e < view->count; ++e)
      std::memcpy(owned->data() + e * elem_size, view->base + e * view->stride, elem_size);
  }
  uint64_t previous = 0;
  for (uint64_t i = 0; i < n; ++i) {
    const uint8_t* q = indices + i * index_size;
    const uint64_t target = index_type == 5121   ? Load<uint8_t>(q)
                            : index_type == 5123 ? Load<uint16_t>(q)
                                                 : Load<uint32_t>(q);
    if (target >= view->count) {
      return name + " sparse index " + std::to_string(target) + " (entry " + std::to_string(i) +
             ") is out of range (count " + std::to_string(view->count) + ")";
    }
    if (i > 0 && target <= previous) {
      return name + " sparse indices are not strictly increasing (entry " + std::to_string(i) + ": " +
             std::to_string(target) + " after " + std::to_string(previous) + ")";
    }
    previous = target;
    std::memcpy(owned->data() + target * elem_size, values + i * elem_size, elem_size);
  }
  view->base = owned->data();
  view->stride = elem_size;
  view->owned = std::move(owned);
  return {};
}

std::string OpenAccessor(const GltfDocument& doc, int64_t index, int components, AccessorView* view) {
  const json& j = doc.json;
  const std::string name = "accessor " + std::to_string(index);
  if (!j.contains("accessors") || !j["accessors"].is_array() || index < 0 ||
      index >= static_cast<int64_t>(j["accessors"].size())) {
    return "accessor index " + std::to_string(index) + " is out of range";
  }
  const json& a = j["accessors"][static_cast<size_t>(index)];
  const bool sparse = a.contains("sparse");
  const int type_components = ComponentsOf(a.value("type", std::string()));
  if (type_components != components) {
    return name + " has type " + a.value("type", std::string("?")) + ", expected " + std::to_string(components) +
           " component(s)";
  }
  const int64_t component_type = Integer(a, "componentType", 0);
  view->component_type = component_type > 0 && component_type <= 0xffff ? static_cast<int>(component_type) : 0;
  const int csize = ComponentSize(view->component_type);
  if (csize == 0) return name + " has an unknown componentType " + std::to_string(view->component_type);
  const int64_t count = Integer(a, "count", -1);
  if (count < 0) return name + " has no valid count";
  view->count = static_cast<uint64_t>(count);
  view->components = components;
  view->normalized = a.value("normalized", false);
  const uint64_t elem_size = static_cast<uint64_t>(csize) * static_cast<uint64_t>(components);
  if (!a.contains("bufferView")) {
    // All zeros (then the sparse substitutions, if any). Cap it so a 200-byte file cannot ask for gigabytes.
    if (view->count > kMaxZeroFilledCount) {
      return name + (sparse ? " is sparse with" : " has") + " no bufferView and an implausible count";
    }
    view->base = nullptr;
    view->stride = elem_size;
    return sparse ? MaterialiseSparse(doc, a, name, view) : std::string();
  }
  const int64_t bv_index = Integer(a, "bufferView", -1);
  std::span<const uint8_t> bytes;
  int64_t stride = 0;
  if (std::string p = OpenBufferView(doc, bv_index, &bytes, &stride); !p.empty()) return name + ": " + p;
  const int64_t acc_offset = Integer(a, "byteOffset", 0);
  if (acc_offset < 0) return name + " has a negative byteOffset";
  view->stride = stride > 0 ? static_cast<uint64_t>(stride) : elem_size;
  if (view->stride > 4096) return "bufferView " + std::to_string(bv_index) + " has an implausible byteStride";
  // glTF 3.6.2.4: elements must not overlap (a stride below the element size would read each
  // byte many times over, and make a sparse copy many times the file's size).
  if (view->stride < elem_size) {
    return name + ": bufferView " + std::to_string(bv_index) + " has a byteStride of " + std::to_string(view->stride) +
           ", below the " + std::to_string(elem_size) + "-byte element";
  }
  // (count - 1) * stride + size must fit after the accessor's offset; checked by division so a
  // huge count cannot wrap the product around.
  const uint64_t avail = bytes.size(), off = static_cast<uint64_t>(acc_offset);
  const bool fits =
      off <= avail &&
      (view->count == 0 || (elem_size <= avail - off && view->count - 1 <= (avail - off - elem_size) / view->stride));
  if (!fits) {
    return name + " (" + std::to_string(view->count) + " elements) runs past the end of bufferView " +
           std::to_string(bv_index);
  }
  // Checked before anything is read: a byte accessor becomes 4x its size in floats. (Without a
  // bufferView, kMaxZeroFilledCount is far below this.)
  if (view->count > kMaxAccessorValues / static_cast<uint64_t>(components)) {
    return name + " has " + std::to_string(view->count) + " elements; at most " + std::to_string(kMaxAccessorValues) +
           " values are read from one accessor";
  }
  view->base = bytes.data() + off;
  return sparse ? MaterialiseSparse(doc, a, name, view) : std::string();
}

float ComponentAsFloat(const uint8_t* p, int type, bool normalized) {
  switch (type) {
    case 5120: {
      const float v = Load<int8_t>(p);
      return normalized ? std::max(v / 127.0f, -1.0f) : v;
    }
    case 5121: {
      const float v = Load<uint8_t>(p);
      return normalized ? v / 255.0f : v;
    }
    case 5122: {
      const float v = Load<int16_t>(p);
      return normalized ? std::max(v / 32767.0f, -1.0f) : v;
    }
    case 5123: {
      const float v = Load<uint16_t>(p);
      return normalized ? v / 65535.0f : v;
    }
    case 5125: return static_cast<float>(Load<uint32_t>(p));
    default: return Load<float>(p);
  }
}

}  // namespace

int64_t AccessorCount(const GltfDocument& doc, int64_t index) {
  const json& j = doc.json;
  if (!j.contains("accessors") || index < 0 || index >= static_cast<int64_t>(j["accessors"].size())) return -1;
  return Integer(j["accessors"][static_cast<size_t>(index)], "count", -1);
}

std::string ReadAccessorFloats(const GltfDocument& doc, int64_t index, int components, std::vector<float>* out) {
  AccessorView v;
  if (std::string problem = OpenAccessor(doc, index, components, &v); !problem.empty()) return problem;
  out->assign(v.count * static_cast<uint64_t>(components), 0.0f);
  if (v.base == nullptr) return {};
  const int csize = ComponentSize(v.component_type);
  for (uint64_t e = 0; e < v.count; ++e) {
    const uint8_t* p = v.base + e * v.stride;
    for (int c = 0; c < components; ++c) {
      (*out)[e * components + c] = ComponentAsFloat(p + c * csize, v.component_type, v.normalized);
    }
  }
  return {};
}

std::string ReadAccessorUints(const GltfDocument& doc, int64_t index, int components, std::vector<uint32_t>* out) {
  AccessorView v;
  if (std::string problem = OpenAccessor(doc, index, components, &v); !problem.empty()) return problem;
  if (v.component_type != 5121 && v.component_type != 5123 && v.component_type != 5125) {
    return "accessor " + std::to_string(index) + " should hold unsigned integers, has componentType " +
           std::to_string(v.component_type);
  }
  out->assign(v.count * static_cast<uint64_t>(components), 0u);
  if (v.base == nullptr) return {};
  const int csize = ComponentSize(v.component_type);
  for (uint64_t e = 0; e < v.count; ++e) {
    const uint8_t* p = v.base + e * v.stride;
    for (int c = 0; c < components; ++c) {
      const uint8_t* q = p + c * csize;
      (*out)[e * components + c] = v.component_type == 5121   ? Load<uint8_t>(q)
                                   : v.component_type == 5123 ? Load<uint16_t>(q)
                                                              : Load<uint32_t>(q);
    }
  }
  return {};
}

}  // namespace skinspheres::lib::detail
