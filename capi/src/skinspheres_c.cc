// The C API's errors, version and the conversions its files share (capi_internal.h).
#include "capi_internal.h"

// The C structs are the C++ ones, byte for byte: contacts are handed out in place.
static_assert(sizeof(skinspheres_sphere_pair) == sizeof(rt::SpherePair));
static_assert(offsetof(skinspheres_sphere_pair, sphere_i) == offsetof(rt::SpherePair, sphere_i));
static_assert(offsetof(skinspheres_sphere_pair, sphere_j) == offsetof(rt::SpherePair, sphere_j));
static_assert(offsetof(skinspheres_sphere_pair, depth) == offsetof(rt::SpherePair, depth));
static_assert(offsetof(skinspheres_sphere_pair, part_i) == offsetof(rt::SpherePair, part_i));
static_assert(offsetof(skinspheres_sphere_pair, part_j) == offsetof(rt::SpherePair, part_j));
// No padding in the narrow phase's C structs (their documented sizes): bindings declare them field
// by field, and a caller may compare them bytewise.
static_assert(sizeof(skinspheres_part_contact) == 56 && sizeof(skinspheres_triangle_contact) == 52);
static_assert(sizeof(Mat4f) == 16 * sizeof(float) && alignof(Mat4f) == alignof(float));
static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float) && alignof(Eigen::Vector3f) == alignof(float));
static_assert(sizeof(skinspheres::Vec4f) == 4 * sizeof(float));
static_assert(SKINSPHERES_OK == static_cast<int>(ErrorCode::kOk) &&
              SKINSPHERES_FILE_NOT_FOUND == static_cast<int>(ErrorCode::kFileNotFound) &&
              SKINSPHERES_FILE_UNREADABLE == static_cast<int>(ErrorCode::kFileUnreadable) &&
              SKINSPHERES_FORMAT_REJECTED == static_cast<int>(ErrorCode::kFormatRejected) &&
              SKINSPHERES_INVALID_DATA == static_cast<int>(ErrorCode::kInvalidData) &&
              SKINSPHERES_VERSION_MISMATCH == static_cast<int>(ErrorCode::kVersionMismatch) &&
              SKINSPHERES_MISMATCHED_ASSET == static_cast<int>(ErrorCode::kMismatchedAsset) &&
              SKINSPHERES_INVALID_ARGUMENT == static_cast<int>(ErrorCode::kInvalidArgument) &&
              SKINSPHERES_NOT_FOUND == static_cast<int>(ErrorCode::kNotFound) &&
              SKINSPHERES_CHECK_FAILED == static_cast<int>(ErrorCode::kCheckFailed));

namespace skinspheres::capi {

namespace {

thread_local std::string t_message;          // set-up errors (allocated)
thread_local const char* t_last_error = "";  // what skinspheres_last_error returns

float FloatAt(const float* base, ptrdiff_t offset) {
  float v;
  std::memcpy(&v, reinterpret_cast<const unsigned char*>(base) + offset, sizeof v);  // may be unaligned
  return v;
}

}  // namespace

skinspheres_status Fail(skinspheres_status status, std::string message) {
  t_message = rt::OneLine(std::move(message));  // a quoted joint name may hold a newline
  t_last_error = t_message.c_str();
  return status;
}
skinspheres_status Fail(const skinspheres::Error& error) {
  return Fail(static_cast<skinspheres_status>(error.code), error.message);
}
// Per frame: a static message, nothing allocated.
skinspheres_status FailStatic(skinspheres_status status, const char* message) {
  t_last_error = message;
  return status;
}
skinspheres_status FromFrame(const rt::FrameStatus& st) {
  if (st.ok()) return SKINSPHERES_OK;
  return FailStatic(static_cast<skinspheres_status>(st.code), st.message);
}

const char* LastError() { return t_last_error; }
void ClearLastError() { t_last_error = ""; }

std::vector<std::string> Names(const char* const* names, size_t count) {
  std::vector<std::string> out;
  out.reserve(count);
  for (size_t k = 0; k < count; ++k) out.emplace_back(names[k] ? names[k] : "");
  return out;
}

// The options as the runtime's settings; false (and the failure recorded) when they are refused.
bool NarrowSettings(const skinspheres_asset_options* options, rt::NarrowPhaseSettings& narrow,
                    skinspheres_status& status) {
  if (options == nullptr) return true;
  const size_t first = offsetof(skinspheres_asset_options, narrow_margin) + sizeof(float);
  if (options->struct_size < first || options->struct_size > sizeof(skinspheres_asset_options)) {
    status = Fail(SKINSPHERES_INVALID_ARGUMENT,
                  "skinspheres_asset_options.struct_size is " + std::to_string(options->struct_size) +
                      ", this library reads " + std::to_string(sizeof(skinspheres_asset_options)) +
                      " (set it to sizeof(skinspheres_asset_options) with this library's header)");
    return false;
  }
  narrow.margin = options->narrow_margin;
  const size_t with_tolerance = offsetof(skinspheres_asset_options, touch_tolerance_share) + sizeof(float);
  if (options->struct_size >= with_tolerance && options->touch_tolerance_share != 0.0f) {
    narrow.touch_tolerance_share = options->touch_tolerance_share;  // range checked by the runtime
  }
  return true;
}

skinspheres_status MakeAsset(skinspheres::Result<rt::SphereSet> set, const skinspheres_asset_options* options,
                             skinspheres_asset** out_asset) {
  rt::NarrowPhaseSettings narrow;
  if (skinspheres_status refused = SKINSPHERES_OK; !NarrowSettings(options, narrow, refused)) return refused;
  if (!set.ok()) return Fail(set.error());
  auto asset = rt::CharacterAsset::Create(std::move(set).value(), narrow);
  if (!asset.ok()) return Fail(asset.error());
  auto handle = std::make_unique<skinspheres_asset>();
  handle->joint_read = rt::JointsReadPerFrame((*asset)->sphere_set());
  handle->asset = std::move(asset).value();
  *out_asset = handle.release();
  return SKINSPHERES_OK;
}

// False (the failure recorded) for a null handle or an index not below count; message: static.
bool InRange(const void* handle, size_t index, size_t count, const char* message) {
  if (handle == nullptr) {
    FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null handle");
    return false;
  }
  if (index >= count) {
    FailStatic(SKINSPHERES_INVALID_ARGUMENT, message);
    return false;
  }
  return true;
}

// names[k] (NULL, the failure recorded, for null names or k out of range).
const char* NameAt(const std::vector<std::string>* names, size_t k, const char* message) {
  if (!InRange(names, k, names ? names->size() : 0, message)) return nullptr;
  return (*names)[k].c_str();
}

Influences SphereInfluences(const skinspheres_asset& asset, size_t sphere) {
  const rt::SphereSet& set = asset.asset->sphere_set();
  const size_t begin = set.influence_offsets[sphere], end = set.influence_offsets[sphere + 1];
  return {std::span(set.influence_joints).subspan(begin, end - begin),
          std::span(set.influence_weights).subspan(begin, end - begin)};
}

bool Packed(const skinspheres_matrix_layout* layout) {
  return layout == nullptr ||
         (layout->joint_stride == kPackedJoints.joint_stride && layout->row_stride == kPackedJoints.row_stride &&
          layout->column_stride == kPackedJoints.column_stride);
}

// Sizes the instance's gather buffers for inputs in these layouts (the first time: set-up
// allocation, which may throw).
void SizeGather(skinspheres_instance& inst, const skinspheres_matrix_layout* joint_layout, const float* positions,
                ptrdiff_t position_stride) {
  if (!Packed(joint_layout) && inst.joint_gather.size() < inst.instance.joint_input_count()) {
    inst.joint_gather.resize(inst.instance.joint_input_count());
  }
  const size_t vertices = inst.instance.asset().source_vertex_count();
  if (positions != nullptr && position_stride != kPackedPositionStride && inst.position_gather.size() < vertices) {
    inst.position_gather.resize(vertices);
  }
}

// The joint matrices as the runtime reads them: the caller's own when packed, else copied into the
// instance's buffer (sized by SizeGather), at most as many as an update reads (a shorter list stays
// shorter, so the runtime refuses it as it would the packed one).
std::span<const Mat4f> Joints(skinspheres_instance& inst, const float* joint_world, size_t joint_count,
                              const skinspheres_matrix_layout* layout) {
  if (joint_world == nullptr) return {};
  if (Packed(layout)) return {reinterpret_cast<const Mat4f*>(joint_world), joint_count};
  const size_t n = std::min(joint_count, inst.joint_gather.size());
  for (size_t j = 0; j < n; ++j) {
    const ptrdiff_t joint = static_cast<ptrdiff_t>(j) * layout->joint_stride;
    for (ptrdiff_t c = 0; c < 4; ++c) {
      for (ptrdiff_t r = 0; r < 4; ++r) {
        inst.joint_gather[j](r, c) = FloatAt(joint_world, joint + r * layout->row_stride + c * layout->column_stride);
      }
    }
  }
  return {inst.joint_gather.data(), n};
}

// The same for positions (x, y, z contiguous, vertices `stride` bytes apart).
std::span<const Eigen::Vector3f> Positions(skinspheres_instance& inst, const float* positions, size_t vertex_count,
                                           ptrdiff_t stride) {
  if (positions == nullptr) return {};
  if (stride == kPackedPositionStride) return {reinterpret_cast<const Eigen::Vector3f*>(positions), vertex_count};
  const size_t n = std::min(vertex_count, inst.position_gather.size());
  for (size_t v = 0; v < n; ++v) {
    const ptrdiff_t vertex = static_cast<ptrdiff_t>(v) * stride;
    for (ptrdiff_t k = 0; k < 3; ++k) {
      inst.position_gather[v][k] = FloatAt(positions, vertex + k * static_cast<ptrdiff_t>(sizeof(float)));
    }
  }
  return {inst.position_gather.data(), n};
}

skinspheres_part_contact ToC(const rt::PartContact& p) {
  skinspheres_part_contact c;
  c.part_a = p.part_a;
  c.part_b = p.part_b;
  c.first_triangle_pair = p.first_triangle_pair;
  c.triangle_pair_count = p.triangle_pair_count;
  c.intersecting_count = p.intersecting_count;
  c.sphere_pair_count = p.sphere_pair_count;
  c.depth = p.depth;
  c.min_distance = p.min_distance;
  std::copy_n(p.normal, 3, c.normal);
  std::copy_n(p.center, 3, c.center);
  c.kind = p.kind == rt::PartContactKind::kPenetrating ? SKINSPHERES_PARTS_PENETRATING : SKINSPHERES_PARTS_TOUCHING;
  return c;
}

skinspheres_triangle_contact ToC(const rt::TriangleContact& t) {
  skinspheres_triangle_contact c;
  c.triangle_a = t.triangle_a;
  c.triangle_b = t.triangle_b;
  c.kind = t.kind == rt::TriangleContactKind::kIntersecting ? SKINSPHERES_TRIANGLES_INTERSECTING
                                                            : SKINSPHERES_TRIANGLES_WITHIN_MARGIN;
  c.distance = t.distance;
  std::copy_n(t.point, 3, c.point);
  std::copy_n(t.on_a, 3, c.on_a);
  std::copy_n(t.on_b, 3, c.on_b);
  return c;
}

skinspheres_sphere_pair ToC(const rt::SpherePair& p) { return std::bit_cast<skinspheres_sphere_pair>(p); }

}  // namespace skinspheres::capi

using namespace skinspheres::capi;

extern "C" {

int skinspheres_version(void) { return skinspheres::LibraryVersion(); }
const char* skinspheres_version_string(void) { return skinspheres::LibraryVersionString(); }

const char* skinspheres_status_string(skinspheres_status status) {
  switch (status) {
    case SKINSPHERES_BUFFER_TOO_SMALL: return "buffer too small";
    case SKINSPHERES_OUT_OF_MEMORY: return "out of memory";
    case SKINSPHERES_INTERNAL_ERROR: return "internal error";
    default: return skinspheres::ToString(static_cast<ErrorCode>(status));
  }
}

const char* skinspheres_last_error(void) { return LastError(); }
void skinspheres_clear_last_error(void) { ClearLastError(); }

}  // extern "C"
