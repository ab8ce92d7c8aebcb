// What the C API's files share (skinspheres/skinspheres.h over the C++ runtime): the handles, the
// error recording, and the conversions between C and C++ records. Internal to the C library.
#pragma once

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

namespace skinspheres::capi {

// Set-up failures keep their message (allocated, one line) in a thread-local string; per-frame
// failures point at a static message (nothing allocated). Both return `status`.
skinspheres_status Fail(skinspheres_status status, std::string message);
skinspheres_status Fail(const skinspheres::Error& error);
skinspheres_status FailStatic(skinspheres_status status, const char* message);
skinspheres_status FromFrame(const rt::FrameStatus& st);
const char* LastError();  // what skinspheres_last_error returns
void ClearLastError();

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

// names[0..count) as strings (NULL as "").
std::vector<std::string> Names(const char* const* names, size_t count);

// The options as the runtime's settings; false (and the failure recorded) when they are refused.
bool NarrowSettings(const skinspheres_asset_options* options, rt::NarrowPhaseSettings& narrow,
                    skinspheres_status& status);

// The asset handle over a loaded set (or the load's failure, recorded).
skinspheres_status MakeAsset(skinspheres::Result<rt::SphereSet> set, const skinspheres_asset_options* options,
                             skinspheres_asset** out_asset);

// False (the failure recorded) for a null handle or an index not below count; message: static.
bool InRange(const void* handle, size_t index, size_t count, const char* message);

// names[k] (NULL, the failure recorded, for null names or k out of range).
const char* NameAt(const std::vector<std::string>* names, size_t k, const char* message);

// A sphere's entries of the set's influence lists (CSR).
struct Influences {
  std::span<const uint16_t> joints;
  std::span<const float> weights;
};
Influences SphereInfluences(const skinspheres_asset& asset, size_t sphere);

// The packed layouts: column-major matrices, 3 floats per vertex.
inline constexpr skinspheres_matrix_layout kPackedJoints = {64, 4, 16};
inline constexpr ptrdiff_t kPackedPositionStride = 3 * sizeof(float);

// Whether a matrix layout is the packed one (NULL: packed).
bool Packed(const skinspheres_matrix_layout* layout);

// Sizes the instance's gather buffers for inputs in these layouts (the first time: set-up
// allocation, which may throw).
void SizeGather(skinspheres_instance& inst, const skinspheres_matrix_layout* joint_layout, const float* positions,
                ptrdiff_t position_stride);

// The joint matrices as the runtime reads them: the caller's own when packed, else copied into the
// instance's buffer (sized by SizeGather), at most as many as an update reads (a shorter list stays
// shorter, so the runtime refuses it as it would the packed one).
std::span<const Mat4f> Joints(skinspheres_instance& inst, const float* joint_world, size_t joint_count,
                              const skinspheres_matrix_layout* layout);

// The same for positions (x, y, z contiguous, vertices `stride` bytes apart).
std::span<const Eigen::Vector3f> Positions(skinspheres_instance& inst, const float* positions, size_t vertex_count,
                                           ptrdiff_t stride);

// The C records of the runtime's.
skinspheres_part_contact ToC(const rt::PartContact& p);
skinspheres_triangle_contact ToC(const rt::TriangleContact& t);
skinspheres_sphere_pair ToC(const rt::SpherePair& p);

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

}  // namespace skinspheres::capi
