// The C API (skinspheres/skinspheres.h) over the C++ runtime: handles wrap CharacterAsset and
// CharacterInstance; no exception crosses the boundary; set-up errors keep their message in a
// thread-local string, per-frame errors point at the runtime's static messages (no allocation).
#include <algorithm>
#include <atomic>
#include <bit>
#include <cstddef>
#include <cstring>
#include <exception>
#include <filesystem>
#include <memory>
#include <new>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/api/joint_mapping.h"
#include "skinspheres/runtime/crowd/crowd.h"
#include "skinspheres/runtime/format/file_io.h"
#include "skinspheres/runtime/format/sphere_set_io.h"
#include "skinspheres/skinspheres.h"
#include "skinspheres/version.h"

using skinspheres::ErrorCode;
using skinspheres::Mat4f;
namespace rt = skinspheres::runtime;

// Reference-counted: the loader's reference, one per instance, one per skinspheres_asset_retain.
struct skinspheres_asset {
  std::shared_ptr<const rt::CharacterAsset> asset;
  std::vector<bool> joint_read;               // JointsReadPerFrame
  mutable std::atomic<size_t> references{1};  // (an instance of a const asset adds one)
};

struct skinspheres_instance {
  rt::CharacterInstance instance;
  const skinspheres_asset* asset = nullptr;  // one reference, dropped by skinspheres_instance_destroy
  // The joint mapping's lists (JointMapping::extra_engine_joints, unmapped_set_joints).
  std::vector<std::string> extra_joints, unmapped_joints;
  // The strided calls' copies of their inputs (set-order count of what an update reads), sized at
  // the first strided call with a layout other than the packed one.
  std::vector<Mat4f> joint_gather;
  std::vector<Eigen::Vector3f> position_gather;
};

// The C structs are the C++ ones, byte for byte: contacts are handed out in place.
static_assert(sizeof(skinspheres_sphere_pair) == sizeof(rt::SpherePair));
static_assert(offsetof(skinspheres_sphere_pair, sphere_i) == offsetof(rt::SpherePair, i));
static_assert(offsetof(skinspheres_sphere_pair, sphere_j) == offsetof(rt::SpherePair, j));
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

namespace {

thread_local std::string t_message;          // set-up errors (allocated)
thread_local const char* t_last_error = "";  // what skinspheres_last_error returns

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

// Runs f; exceptions (allocation failure at set-up, a bug) become a status.
template <typename F>
skinspheres_status Guard(F&& f) noexcept {
  try {
    return f();
  } catch (const std::bad_alloc&) {
    return FailStatic(SKINSPHERES_OUT_OF_MEMORY, "out of memory");
  } catch (const std::length_error&) {  // a count beyond what a vector can hold (SIZE_MAX joints)
    return FailStatic(SKINSPHERES_OUT_OF_MEMORY, "out of memory: a count too large to allocate");
  } catch (const std::exception& e) {
    try {
      return Fail(SKINSPHERES_INTERNAL_ERROR, std::string("internal error: ") + e.what());
    } catch (...) {
      return FailStatic(SKINSPHERES_INTERNAL_ERROR, "internal error");
    }
  } catch (...) {
    return FailStatic(SKINSPHERES_INTERNAL_ERROR, "internal error");
  }
}

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

// A sphere's entries of the set's influence lists (CSR).
struct Influences {
  std::span<const uint16_t> joints;
  std::span<const float> weights;
};
Influences SphereInfluences(const skinspheres_asset& asset, size_t sphere) {
  const rt::SphereSet& set = asset.asset->sphere_set();
  const size_t begin = set.influence_offsets[sphere], end = set.influence_offsets[sphere + 1];
  return {std::span(set.influence_joints).subspan(begin, end - begin),
          std::span(set.influence_weights).subspan(begin, end - begin)};
}

// The packed layouts: column-major matrices, 3 floats per vertex.
constexpr skinspheres_matrix_layout kPackedJoints = {64, 4, 16};
constexpr ptrdiff_t kPackedPositionStride = 3 * sizeof(float);

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

float FloatAt(const float* base, ptrdiff_t offset) {
  float v;
  std::memcpy(&v, reinterpret_cast<const unsigned char*>(base) + offset, sizeof v);  // may be unaligned
  return v;
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
  c.triangle_a = t.t;
  c.triangle_b = t.u;
  c.kind = t.kind == rt::TriangleContactKind::kIntersecting ? SKINSPHERES_TRIANGLES_INTERSECTING
                                                            : SKINSPHERES_TRIANGLES_WITHIN_MARGIN;
  c.distance = t.distance;
  std::copy_n(t.point, 3, c.point);
  std::copy_n(t.on_t, 3, c.on_a);
  std::copy_n(t.on_u, 3, c.on_b);
  return c;
}

skinspheres_sphere_pair ToC(const rt::SpherePair& p) { return std::bit_cast<skinspheres_sphere_pair>(p); }

// Copies min(capacity, total) entries of `from` into out (as their C structs), *out_count = the
// total; SKINSPHERES_BUFFER_TOO_SMALL (too_small: static) when they do not all fit.
template <typename T, typename C>
skinspheres_status CopyOut(std::span<const T> from, C* out, size_t capacity, size_t* out_count, const char* too_small) {
  const size_t n = std::min(from.size(), capacity);
  for (size_t k = 0; k < n; ++k) out[k] = ToC(from[k]);
  if (out_count) *out_count = from.size();
  if (n < from.size()) return FailStatic(SKINSPHERES_BUFFER_TOO_SMALL, too_small);
  return SKINSPHERES_OK;
}

// A crowd input as the runtime reads it (the strided one copied into the instance's buffers; its
// positions only in exact mode, the only one that reads them).
rt::CharacterFrameInput FrameInput(skinspheres_instance& inst, const skinspheres_frame_input& in, rt::RefitMode) {
  return {Joints(inst, in.joint_world, in.joint_count, nullptr),
          Positions(inst, in.positions, in.vertex_count, kPackedPositionStride)};
}
rt::CharacterFrameInput FrameInput(skinspheres_instance& inst, const skinspheres_frame_input_strided& in,
                                   rt::RefitMode mode) {
  const float* positions = mode == rt::RefitMode::kExact ? in.positions : nullptr;
  return {Joints(inst, in.joint_world, in.joint_count, in.joint_layout),
          Positions(inst, positions, in.vertex_count, in.position_stride)};
}
void SizeGather(skinspheres_instance&, const skinspheres_frame_input&, rt::RefitMode) {}
void SizeGather(skinspheres_instance& inst, const skinspheres_frame_input_strided& in, rt::RefitMode mode) {
  SizeGather(inst, in.joint_layout, mode == rt::RefitMode::kExact ? in.positions : nullptr, in.position_stride);
}

template <typename Input>
struct CrowdWork {
  skinspheres_instance* const* instances;
  const Input* inputs;
  rt::RefitMode mode;
  bool find_contacts;              // then the narrow phase (skinspheres_crowd_update_and_find_contacts)
  size_t count;                    // instances
  size_t block;                    // instances per index of the parallel loop (16 or 1)
  std::atomic<bool> all_ok{true};  // set to false by any thread; read after the loop
};

// The range in blocks of 16 through rt::CrowdRange (consecutive instances of one asset refitted
// together when the CPU has AVX-512F), the C inputs converted on the stack.
template <typename Input>
void RunCrowdRange(CrowdWork<Input>* work, size_t begin, size_t end) {
  constexpr size_t kBlock = 16;
  for (size_t first = begin; first < end; first += kBlock) {
    const size_t count = std::min(kBlock, end - first);
    rt::CharacterInstance* instances[kBlock];
    rt::CharacterFrameInput inputs[kBlock];
    for (size_t k = 0; k < count; ++k) {
      instances[k] = &work->instances[first + k]->instance;
      inputs[k] = FrameInput(*work->instances[first + k], work->inputs[first + k], work->mode);
    }
    if (!rt::CrowdRange(std::span(instances, count), std::span(inputs, count), work->mode, work->find_contacts).ok()) {
      work->all_ok.store(false, std::memory_order_relaxed);
    }
  }
}

// Blocks [begin, end) of the loop: instances [begin * block, min(end * block, count)).
template <typename Input>
void RunCrowdBlocks(void* context, size_t begin, size_t end) {
  auto* work = static_cast<CrowdWork<Input>*>(context);
  RunCrowdRange(work, begin * work->block, std::min(end * work->block, work->count));
}

// Update + FindSpherePairs (+ FindContacts) of every instance through the engine's loop or the default one.
template <typename Input>
skinspheres_status RunCrowd(skinspheres_instance* const* instances, const Input* inputs, size_t count,
                            skinspheres_refit_mode mode, bool find_contacts, skinspheres_parallel_for_fn parallel_for,
                            void* user) {
  return Guard([&] {
    if (count != 0 && (instances == nullptr || inputs == nullptr)) {
      return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instances or inputs");
    }
    if (mode != SKINSPHERES_MODE_EXACT && mode != SKINSPHERES_MODE_FAST) {
      return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "unknown refit mode");
    }
    for (size_t i = 0; i < count; ++i) {
      if (instances[i] == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instance");
    }
    const rt::RefitMode rt_mode = mode == SKINSPHERES_MODE_FAST ? rt::RefitMode::kFast : rt::RefitMode::kExact;
    // Strided inputs: the instances' gather buffers, sized here (the loop then allocates nothing).
    for (size_t i = 0; i < count; ++i) SizeGather(*instances[i], inputs[i], rt_mode);
    // The loop's indices are blocks of instances, as rt::CrowdUpdateAndFindSpherePairs's (CrowdBlock): no range
    // it hands out cuts a batch of 16 short.
    const size_t block = rt::CrowdBlock(rt_mode, find_contacts);
    CrowdWork<Input> work{instances, inputs, rt_mode, find_contacts, count, block};
    const size_t blocks = (count + block - 1) / block;
    if (parallel_for != nullptr) {
      if (count) parallel_for(user, blocks, 1, &RunCrowdBlocks<Input>, &work);
    } else {
      skinspheres::DefaultParallelFor()(
          blocks, 1, [&work](size_t begin, size_t end) { RunCrowdBlocks<Input>(&work, begin, end); });
    }
    if (!work.all_ok.load()) {
      return FailStatic(SKINSPHERES_INVALID_DATA, "at least one instance failed; see skinspheres_instance_status");
    }
    return SKINSPHERES_OK;
  });
}

}  // namespace

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

const char* skinspheres_last_error(void) { return t_last_error; }
void skinspheres_clear_last_error(void) { t_last_error = ""; }

skinspheres_status skinspheres_asset_load_file(const char* path, skinspheres_asset** out_asset) {
  return skinspheres_asset_load_file_with(path, nullptr, out_asset);
}

skinspheres_status skinspheres_asset_load_file_with(const char* path, const skinspheres_asset_options* options,
                                                    skinspheres_asset** out_asset) {
  return Guard([&] {
    if (out_asset) *out_asset = nullptr;
    if (path == nullptr || out_asset == nullptr)
      return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null path or out_asset");
    // UTF-8 on every platform (on Windows a char path would otherwise be read in the code page).
    const std::u8string utf8(reinterpret_cast<const char8_t*>(path));
    return MakeAsset(rt::LoadSphereSet(std::filesystem::path(utf8)), options, out_asset);
  });
}

skinspheres_status skinspheres_asset_load_memory(const void* data, size_t size, const char* name,
                                                 skinspheres_asset** out_asset) {
  return skinspheres_asset_load_memory_with(data, size, name, nullptr, out_asset);
}

skinspheres_status skinspheres_asset_load_memory_with(const void* data, size_t size, const char* name,
                                                      const skinspheres_asset_options* options,
                                                      skinspheres_asset** out_asset) {
  return Guard([&] {
    if (out_asset) *out_asset = nullptr;
    if ((data == nullptr && size != 0) || out_asset == nullptr) {
      return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null data or out_asset");
    }
    const std::span<const std::byte> bytes(static_cast<const std::byte*>(data), size);
    return MakeAsset(rt::ReadSphereSet(bytes, name ? name : "<memory>"), options, out_asset);
  });
}

float skinspheres_asset_narrow_margin(const skinspheres_asset* asset) {
  const rt::NarrowPhaseData* narrow = asset ? asset->asset->narrow_phase() : nullptr;
  return narrow ? narrow->margin() : 0.0f;
}

int skinspheres_asset_contact_rules(const skinspheres_asset* asset) {
  return asset ? static_cast<int>(asset->asset->sphere_set().contact_rules) : SKINSPHERES_RULES_SPHERE_PAIRS;
}

uint32_t skinspheres_asset_contact_hops(const skinspheres_asset* asset) {
  return asset ? asset->asset->sphere_set().contact_hops : 0u;
}

float skinspheres_asset_rest_gap(const skinspheres_asset* asset) {
  return asset ? asset->asset->sphere_set().rest_gap : 0.0f;
}

float skinspheres_asset_touch_tolerance(const skinspheres_asset* asset) {
  const rt::NarrowPhaseData* narrow = asset ? asset->asset->narrow_phase() : nullptr;
  return narrow ? narrow->touch_tolerance() : 0.0f;
}

void skinspheres_asset_release(skinspheres_asset* asset) {
  if (asset != nullptr && asset->references.fetch_sub(1, std::memory_order_acq_rel) == 1) delete asset;
}

skinspheres_asset* skinspheres_asset_retain(skinspheres_asset* asset) {
  if (asset != nullptr) asset->references.fetch_add(1, std::memory_order_relaxed);
  return asset;
}

size_t skinspheres_asset_sphere_count(const skinspheres_asset* asset) { return asset ? asset->asset->size() : 0; }
size_t skinspheres_asset_joint_count(const skinspheres_asset* asset) { return asset ? asset->asset->joint_count() : 0; }
const char* skinspheres_asset_joint_name(const skinspheres_asset* asset, size_t joint) {
  return NameAt(asset ? &asset->asset->sphere_set().joint_names : nullptr, joint, "joint index out of range");
}
const float* skinspheres_asset_joint_rest_world(const skinspheres_asset* asset, size_t joint) {
  if (!InRange(asset, joint, asset ? asset->asset->joint_count() : 0, "joint index out of range")) return nullptr;
  return asset->asset->sphere_set().joint_rest_world[joint].data();
}
int skinspheres_asset_joint_is_read(const skinspheres_asset* asset, size_t joint) {
  return asset && joint < asset->joint_read.size() && asset->joint_read[joint] ? 1 : 0;
}
size_t skinspheres_asset_part_count(const skinspheres_asset* asset) {
  return asset ? asset->asset->sphere_set().parts.size() : 0;
}
const char* skinspheres_asset_part_name(const skinspheres_asset* asset, size_t part) {
  if (!InRange(asset, part, asset ? asset->asset->sphere_set().parts.size() : 0, "part index out of range"))
    return nullptr;
  return asset->asset->sphere_set().parts[part].name.c_str();
}

skinspheres_status skinspheres_asset_sphere_part(const skinspheres_asset* asset, size_t sphere, size_t* out_part) {
  if (out_part == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null out_part");
  if (!InRange(asset, sphere, asset ? asset->asset->size() : 0, "sphere index out of range"))
    return SKINSPHERES_INVALID_ARGUMENT;
  *out_part = asset->asset->sphere_set().sphere_part[sphere];
  return SKINSPHERES_OK;
}

skinspheres_status skinspheres_asset_sphere_joints(const skinspheres_asset* asset, size_t sphere, uint32_t* out_joints,
                                                   float* out_weights, size_t capacity, size_t* out_count) {
  if (out_count == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null out_count");
  *out_count = 0;
  if (!InRange(asset, sphere, asset ? asset->asset->size() : 0, "sphere index out of range"))
    return SKINSPHERES_INVALID_ARGUMENT;
  const Influences in = SphereInfluences(*asset, sphere);
  for (size_t k = 0; k < std::min(capacity, in.joints.size()); ++k) {
    if (out_joints) out_joints[k] = in.joints[k];
    if (out_weights) out_weights[k] = in.weights[k];
  }
  *out_count = in.joints.size();
  if (capacity < in.joints.size()) {
    return FailStatic(SKINSPHERES_BUFFER_TOO_SMALL, "the joint buffer holds fewer entries than the sphere's joints");
  }
  return SKINSPHERES_OK;
}

skinspheres_status skinspheres_asset_sphere_joint(const skinspheres_asset* asset, size_t sphere, size_t* out_joint) {
  if (out_joint == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null out_joint");
  if (!InRange(asset, sphere, asset ? asset->asset->size() : 0, "sphere index out of range"))
    return SKINSPHERES_INVALID_ARGUMENT;
  const Influences in = SphereInfluences(*asset, sphere);
  if (in.joints.empty()) return FailStatic(SKINSPHERES_INVALID_DATA, "the sphere has no joints");
  size_t best = 0;
  for (size_t k = 1; k < in.joints.size(); ++k) {
    if (in.weights[k] > in.weights[best] || (in.weights[k] == in.weights[best] && in.joints[k] < in.joints[best])) {
      best = k;
    }
  }
  *out_joint = in.joints[best];
  return SKINSPHERES_OK;
}
size_t skinspheres_asset_vertex_count(const skinspheres_asset* asset) {
  return asset ? asset->asset->source_vertex_count() : 0;
}
int skinspheres_asset_is_fast_only(const skinspheres_asset* asset) {
  return asset && asset->asset->sphere_set().fast_only ? 1 : 0;
}

skinspheres_status skinspheres_asset_check(const skinspheres_asset* asset, const char* const* joint_names,
                                           size_t joint_count, size_t vertex_count) {
  return Guard([&] {
    if (asset == nullptr || (joint_names == nullptr && joint_count != 0)) {
      return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null asset or joint_names");
    }
    const std::vector<std::string> names = Names(joint_names, joint_count);
    if (auto err = asset->asset->Matches(names, vertex_count)) return Fail(*err);
    return SKINSPHERES_OK;
  });
}

skinspheres_status skinspheres_instance_create(const skinspheres_asset* asset, const char* const* joint_names,
                                               size_t joint_count, skinspheres_instance** out_instance) {
  return Guard([&] {
    if (out_instance) *out_instance = nullptr;
    if (asset == nullptr || out_instance == nullptr || (joint_names == nullptr && joint_count != 0)) {
      return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null asset, joint_names or out_instance");
    }
    skinspheres::Result<rt::CharacterInstance> created = rt::CharacterInstance::Create(asset->asset);
    rt::JointMapping mapping;
    if (joint_names != nullptr) {
      auto mapped = rt::MapJoints(asset->asset->sphere_set(), Names(joint_names, joint_count));
      if (!mapped.ok()) return Fail(mapped.error());
      mapping = std::move(mapped).value();
      created = rt::CharacterInstance::Create(asset->asset, mapping);
    }
    if (!created.ok()) return Fail(created.error());
    auto instance = std::make_unique<skinspheres_instance>(std::move(created).value());
    instance->extra_joints = std::move(mapping.extra_engine_joints);
    instance->unmapped_joints = std::move(mapping.unmapped_set_joints);
    asset->references.fetch_add(1, std::memory_order_relaxed);  // nothing throws after this
    instance->asset = asset;
    *out_instance = instance.release();
    return SKINSPHERES_OK;
  });
}

void skinspheres_instance_destroy(skinspheres_instance* instance) {
  if (instance == nullptr) return;
  skinspheres_asset* asset = const_cast<skinspheres_asset*>(instance->asset);  // immutable: only counted
  delete instance;
  skinspheres_asset_release(asset);
}

skinspheres_asset* skinspheres_instance_asset(const skinspheres_instance* instance) {
  return instance ? const_cast<skinspheres_asset*>(instance->asset) : nullptr;
}

size_t skinspheres_instance_extra_joint_count(const skinspheres_instance* instance) {
  return instance ? instance->extra_joints.size() : 0;
}
const char* skinspheres_instance_extra_joint_name(const skinspheres_instance* instance, size_t k) {
  return NameAt(instance ? &instance->extra_joints : nullptr, k, "extra joint index out of range");
}
size_t skinspheres_instance_unmapped_joint_count(const skinspheres_instance* instance) {
  return instance ? instance->unmapped_joints.size() : 0;
}
const char* skinspheres_instance_unmapped_joint_name(const skinspheres_instance* instance, size_t k) {
  return NameAt(instance ? &instance->unmapped_joints : nullptr, k, "unmapped joint index out of range");
}

size_t skinspheres_instance_joint_count(const skinspheres_instance* instance) {
  return instance ? instance->instance.joint_input_count() : 0;
}

skinspheres_status skinspheres_instance_update_fast(skinspheres_instance* instance, const float* joint_world,
                                                    size_t joint_count) {
  return skinspheres_instance_update_fast_strided(instance, joint_world, joint_count, nullptr);
}

skinspheres_status skinspheres_instance_update_exact(skinspheres_instance* instance, const float* positions,
                                                     size_t vertex_count, const float* joint_world,
                                                     size_t joint_count) {
  return skinspheres_instance_update_exact_strided(instance, positions, vertex_count, kPackedPositionStride,
                                                   joint_world, joint_count, nullptr);
}

skinspheres_status skinspheres_instance_update_fast_strided(skinspheres_instance* instance, const float* joint_world,
                                                            size_t joint_count,
                                                            const skinspheres_matrix_layout* joint_layout) {
  return Guard([&] {
    if (instance == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instance");
    if (joint_world == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "fast mode needs joint matrices");
    SizeGather(*instance, joint_layout, nullptr, kPackedPositionStride);
    return FromFrame(instance->instance.UpdateFast(Joints(*instance, joint_world, joint_count, joint_layout)));
  });
}

skinspheres_status skinspheres_instance_update_exact_strided(skinspheres_instance* instance, const float* positions,
                                                             size_t vertex_count, ptrdiff_t position_stride,
                                                             const float* joint_world, size_t joint_count,
                                                             const skinspheres_matrix_layout* joint_layout) {
  return Guard([&] {
    if (instance == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instance");
    if (positions == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "exact mode needs vertex positions");
    if (joint_world == nullptr && joint_count != 0) {
      return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null joint_world with a joint count");
    }
    SizeGather(*instance, joint_layout, positions, position_stride);
    return FromFrame(instance->instance.UpdateExact(Positions(*instance, positions, vertex_count, position_stride),
                                                    Joints(*instance, joint_world, joint_count, joint_layout)));
  });
}

skinspheres_status skinspheres_instance_find_sphere_pairs(skinspheres_instance* instance, size_t* out_count) {
  return Guard([&] {
    if (out_count) *out_count = 0;
    if (instance == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instance");
    const size_t n = instance->instance.FindSpherePairs().size();
    if (out_count) *out_count = n;
    return FromFrame(instance->instance.status());
  });
}

skinspheres_status skinspheres_instance_get_sphere_pairs(const skinspheres_instance* instance,
                                                         skinspheres_sphere_pair* out, size_t capacity,
                                                         size_t* out_count) {
  if (out_count) *out_count = 0;
  if (instance == nullptr || (out == nullptr && capacity != 0)) {
    return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instance or buffer");
  }
  return CopyOut(instance->instance.sphere_pairs(), out, capacity, out_count,
                 "the sphere-pair buffer holds fewer entries than the count");
}

const skinspheres_sphere_pair* skinspheres_instance_sphere_pairs(const skinspheres_instance* instance,
                                                                 size_t* out_count) {
  if (out_count) *out_count = 0;
  if (instance == nullptr) return nullptr;
  const auto contacts = instance->instance.sphere_pairs();
  if (out_count) *out_count = contacts.size();
  return reinterpret_cast<const skinspheres_sphere_pair*>(contacts.data());
}

const float* skinspheres_instance_spheres(const skinspheres_instance* instance, size_t* out_count) {
  if (out_count) *out_count = 0;
  if (instance == nullptr || !instance->instance.spheres_valid()) return nullptr;
  const auto spheres = instance->instance.spheres();
  if (out_count) *out_count = spheres.size();
  return spheres.empty() ? nullptr : spheres.data()->data();
}

skinspheres_status skinspheres_instance_status(const skinspheres_instance* instance, const char** message) {
  if (instance == nullptr) {
    if (message) *message = "null instance";
    return SKINSPHERES_INVALID_ARGUMENT;
  }
  const rt::FrameStatus st = instance->instance.status();
  if (message) *message = st.message;
  return static_cast<skinspheres_status>(st.code);
}

skinspheres_status skinspheres_instance_reserve_contacts(skinspheres_instance* instance, size_t count) {
  return Guard([&] {
    if (instance == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instance");
    instance->instance.ReserveContacts(count);
    return SKINSPHERES_OK;
  });
}

skinspheres_status skinspheres_instance_reserve_sphere_pairs(skinspheres_instance* instance, size_t count) {
  return Guard([&] {
    if (instance == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instance");
    instance->instance.ReserveSpherePairs(count);
    return SKINSPHERES_OK;
  });
}

int skinspheres_asset_has_triangle_contacts(const skinspheres_asset* asset) {
  return asset && asset->asset->narrow_phase() != nullptr ? 1 : 0;
}

skinspheres_status skinspheres_instance_find_contacts(skinspheres_instance* instance, const float* positions,
                                                      size_t vertex_count, size_t* out_part_pairs,
                                                      size_t* out_triangle_pairs) {
  return skinspheres_instance_find_contacts_strided(instance, positions, vertex_count, kPackedPositionStride,
                                                    out_part_pairs, out_triangle_pairs);
}

skinspheres_status skinspheres_instance_find_contacts_strided(skinspheres_instance* instance, const float* positions,
                                                              size_t vertex_count, ptrdiff_t position_stride,
                                                              size_t* out_part_pairs, size_t* out_triangle_pairs) {
  return Guard([&] {
    if (out_part_pairs) *out_part_pairs = 0;
    if (out_triangle_pairs) *out_triangle_pairs = 0;
    if (instance == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instance");
    if (positions == nullptr && vertex_count != 0) {
      return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null positions with a vertex count");
    }
    SizeGather(*instance, nullptr, positions, position_stride);
    const rt::FrameStatus st =
        instance->instance.FindContacts(Positions(*instance, positions, vertex_count, position_stride));
    const rt::FrameContacts& found = instance->instance.contacts();
    if (out_part_pairs) *out_part_pairs = found.parts.size();
    if (out_triangle_pairs) *out_triangle_pairs = found.triangle_pairs.size();
    return FromFrame(st);
  });
}

skinspheres_status skinspheres_instance_get_part_contacts(const skinspheres_instance* instance,
                                                          skinspheres_part_contact* out, size_t capacity,
                                                          size_t* out_count) {
  if (out_count) *out_count = 0;
  if (instance == nullptr || (out == nullptr && capacity != 0)) {
    return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instance or buffer");
  }
  return CopyOut(std::span<const rt::PartContact>(instance->instance.contacts().parts), out, capacity, out_count,
                 "the part-contact buffer holds fewer entries than the count");
}

skinspheres_status skinspheres_instance_get_triangle_contacts(const skinspheres_instance* instance, size_t part_contact,
                                                              skinspheres_triangle_contact* out, size_t capacity,
                                                              size_t* out_count) {
  if (out_count) *out_count = 0;
  if (instance == nullptr || (out == nullptr && capacity != 0)) {
    return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instance or buffer");
  }
  const rt::FrameContacts& found = instance->instance.contacts();
  std::span<const rt::TriangleContact> pairs = found.triangle_pairs;
  if (part_contact != static_cast<size_t>(SKINSPHERES_ALL_PART_PAIRS)) {
    if (part_contact >= found.parts.size()) {
      return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "part_contact is not below the part-pair count");
    }
    const rt::PartContact& p = found.parts[part_contact];
    pairs = pairs.subspan(p.first_triangle_pair, p.triangle_pair_count);
  }
  return CopyOut(pairs, out, capacity, out_count, "the triangle-contact buffer holds fewer entries than the count");
}

skinspheres_status skinspheres_crowd_update_and_find_sphere_pairs(skinspheres_instance* const* instances,
                                                                  const skinspheres_frame_input* inputs, size_t count,
                                                                  skinspheres_refit_mode mode,
                                                                  skinspheres_parallel_for_fn parallel_for,
                                                                  void* user) {
  return RunCrowd(instances, inputs, count, mode, /*find_contacts=*/false, parallel_for, user);
}

skinspheres_status skinspheres_crowd_update_and_find_contacts(skinspheres_instance* const* instances,
                                                              const skinspheres_frame_input* inputs, size_t count,
                                                              skinspheres_refit_mode mode,
                                                              skinspheres_parallel_for_fn parallel_for, void* user) {
  return RunCrowd(instances, inputs, count, mode, /*find_contacts=*/true, parallel_for, user);
}

skinspheres_status skinspheres_crowd_update_and_find_sphere_pairs_strided(skinspheres_instance* const* instances,
                                                                          const skinspheres_frame_input_strided* inputs,
                                                                          size_t count, skinspheres_refit_mode mode,
                                                                          skinspheres_parallel_for_fn parallel_for,
                                                                          void* user) {
  return RunCrowd(instances, inputs, count, mode, /*find_contacts=*/false, parallel_for, user);
}

skinspheres_status skinspheres_crowd_update_and_find_contacts_strided(skinspheres_instance* const* instances,
                                                                      const skinspheres_frame_input_strided* inputs,
                                                                      size_t count, skinspheres_refit_mode mode,
                                                                      skinspheres_parallel_for_fn parallel_for,
                                                                      void* user) {
  return RunCrowd(instances, inputs, count, mode, /*find_contacts=*/true, parallel_for, user);
}

}  // extern "C"
