// The binary sphere-set layout the writer and the reader share (sphere_set_binary.h: header fields,
// sections, alignment). Internal to the runtime library.
#pragma once

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "skinspheres/runtime/format/sphere_set_binary.h"

namespace skinspheres::runtime::internal {

static_assert(
    std::endian::native == std::endian::little,
    "the binary sphere-set layout is little-endian and read in place: big-endian hosts need a byte-swapping reader");
static_assert(sizeof(Mat4f) == 16 * sizeof(float) && sizeof(Eigen::Vector3f) == 3 * sizeof(float));

// Little-endian loads from unaligned bytes.
inline uint64_t Load64(const std::byte* p) {
  uint64_t v;
  std::memcpy(&v, p, 8);
  return v;
}
inline uint32_t Load32(const std::byte* p) {
  uint32_t v;
  std::memcpy(&v, p, 4);
  return v;
}

// Header field offsets (sphere_set_binary.h).
constexpr size_t kChecksumAt = 8, kVersionAt = 16, kFlagsAt = 20, kFileSizeAt = 24, kSectionCountAt = 32,
                 kSphereCountAt = 36, kJointCountAt = 40, kPartCountAt = 44, kVertexCountAt = 48, kTriangleCountAt = 52,
                 kBindCountAt = 56;
constexpr size_t kChecksummedFrom = 16;

constexpr size_t kFirstFastOnlyOmitted = static_cast<size_t>(SphereSetSection::kVertexOffsets);  // 17
constexpr size_t kFirstMeshSection = static_cast<size_t>(SphereSetSection::kTriangleVertices);   // 21

struct SectionInfo {
  const char* name;
  uint32_t element_size;
};
inline constexpr std::array<SectionInfo, kSphereSetSectionCount> kSections = {{
    {"string_offsets", 4},
    {"string_bytes", 1},
    {"joint_parents", 4},
    {"joint_rest_world", 4},
    {"part_joint_offsets", 4},
    {"part_joints", 4},
    {"centers_rest", 4},
    {"radii_rest", 4},
    {"radii_fast", 4},
    {"sphere_part", 2},
    {"sphere_joint", 2},
    {"sphere_level", 2},
    {"influence_offsets", 4},
    {"influence_joints", 2},
    {"influence_weights", 4},
    {"excluded_pairs", 4},
    {"vertex_offsets", 4},
    {"vertices", 4},
    {"triangle_offsets", 4},
    {"triangles", 4},
    {"triangle_vertices", 4},
    {"positions_bind", 4},
    {"bind_joints", 4},
    {"bind_inverse", 4},
    {"mesh_influence_offsets", 4},
    {"mesh_influence_binds", 2},
    {"mesh_influence_weights", 4},
    {"influence_reach", 4},
    {"fast_reference_inverse", 4},
    {"fast_reference_spheres", 4},
    {"reach_group_offsets", 4},
    {"reach_group_radii", 4},
    {"reach_group_weights", 4},
    {"piece_points", 4},
    {"piece_offsets", 4},
    {"pieces", 4},
    {"reach_group_blend", 4},
    {"reach_group_deviation", 4},
    {"contact_rules", 4},
    {"rest_gap", 4},
}};

// Which sections a file of this layout version with these flags holds (index id - 1).
inline bool SectionPresent(size_t id, uint32_t flags, uint32_t version) {
  if (id >= static_cast<size_t>(SphereSetSection::kContactRules)) return version >= kSphereSetBinaryVersion;
  if (id >= static_cast<size_t>(SphereSetSection::kReachGroupBlend))
    return version >= kSphereSetBinaryVersionWithoutRules;
  if (id >= static_cast<size_t>(SphereSetSection::kPiecePoints)) {
    return version >= kSphereSetBinaryVersionWithoutBlends && (flags & kSphereSetBinaryFlagHasMesh) != 0;
  }
  if (id >= static_cast<size_t>(SphereSetSection::kFastReferenceInverse))
    return version >= kSphereSetBinaryVersionWithoutPieces;
  if (id == static_cast<size_t>(SphereSetSection::kInfluenceReach))
    return version >= kSphereSetBinaryVersionWithoutReference;
  if (id >= kFirstMeshSection) return (flags & kSphereSetBinaryFlagHasMesh) != 0;
  if (id >= kFirstFastOnlyOmitted) return (flags & kSphereSetBinaryFlagFastOnly) == 0;
  return true;
}

inline size_t AlignUp(size_t n) {
  return (n + kSphereSetBinaryAlignment - 1) / kSphereSetBinaryAlignment * kSphereSetBinaryAlignment;
}

}  // namespace skinspheres::runtime::internal
