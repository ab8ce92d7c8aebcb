// The binary sphere-set asset (".ssb"): the whole SphereSet (sphere_set.h), mesh included, in a
// little-endian layout that loads without parsing and can be memory-mapped. JSON (sphere_set_io.h)
// stays the interchange format; converting one into the other and back is bit-exact.
// Layout (header, section table, sections 1-40, what each version adds, the fast-only variant):
// docs/FORMAT.md#binary-layout. Version 6 is written; versions 1-5 are read, without the sections
// added since. Offsets, never pointers: the file works at any address.
// Errors: reading refuses a wrong magic (kFormatRejected), another version (kVersionMismatch), and
// truncation, checksum mismatch or any structural fault (kInvalidData), with one line
// "<source>: <problem>", allocating nothing before the sizes are known to fit the input;
// ToSphereSet then refuses what the JSON reader would (docs/FORMAT.md#reading-and-its-errors).
// A big-endian host does not compile this file.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "skinspheres/runtime/error.h"
#include "skinspheres/runtime/format/sphere_set.h"

namespace skinspheres::runtime {

inline constexpr unsigned char kSphereSetBinaryMagic[8] = {0x89, 'S', 'S', 'B', '\r', '\n', 0x1A, '\n'};
inline constexpr uint32_t kSphereSetBinaryVersion = 6;                  // written
inline constexpr uint32_t kSphereSetBinaryVersionWithoutRules = 5;      // read (no sections 39-40)
inline constexpr uint32_t kSphereSetBinaryVersionWithoutBlends = 4;     // read (no sections 37-40)
inline constexpr uint32_t kSphereSetBinaryVersionWithoutPieces = 3;     // read (no sections 34-38)
inline constexpr uint32_t kSphereSetBinaryVersionWithoutReference = 2;  // read (no sections 29-38)
inline constexpr uint32_t kSphereSetBinaryVersionWithoutReach = 1;      // read (no sections 28-38)
inline constexpr size_t kSphereSetBinaryHeaderSize = 64;
inline constexpr size_t kSphereSetBinarySectionEntrySize = 24;
inline constexpr size_t kSphereSetBinaryAlignment = 16;
inline constexpr uint32_t kSphereSetBinaryFlagFastOnly = 1u << 0;
inline constexpr uint32_t kSphereSetBinaryFlagHasMesh = 1u << 1;

enum class SphereSetSection : uint32_t {
  kStringOffsets = 1,
  kStringBytes,
  kJointParents,
  kJointRestWorld,
  kPartJointOffsets,
  kPartJoints,
  kCentersRest,
  kRadiiRest,
  kRadiiFast,
  kSpherePart,
  kSphereJoint,
  kSphereLevel,
  kInfluenceOffsets,
  kInfluenceJoints,
  kInfluenceWeights,
  kExcludedPairs,
  kVertexOffsets,
  kVertices,
  kTriangleOffsets,
  kTriangles,
  kTriangleVertices,
  kPositionsBind,
  kBindJoints,
  kBindInverse,
  kMeshInfluenceOffsets,
  kMeshInfluenceBinds,
  kMeshInfluenceWeights,
  kInfluenceReach,
  kFastReferenceInverse,
  kFastReferenceSpheres,
  kReachGroupOffsets,
  kReachGroupRadii,
  kReachGroupWeights,
  kPiecePoints,
  kPieceOffsets,
  kPieces,
  kReachGroupBlend,
  kReachGroupDeviation,
  kContactRules,
  kRestGap,
};
inline constexpr uint32_t kSphereSetSectionCount = 40;  // ids 1..40

enum class SphereSetBinaryContent : uint8_t {
  kFull,      // everything, mesh included: converts back to the same JSON
  kFastOnly,  // what fast refit reads (no vertex/triangle lists, no mesh)
};

// XXH64 (Collet's xxHash, 64-bit) of data: the file checksum.
uint64_t Xxh64(std::span<const std::byte> data, uint64_t seed = 0);

// True when data starts with kSphereSetBinaryMagic.
bool IsSphereSetBinary(std::span<const std::byte> data);

// The encoded file. A set with fast_only set is always written fast-only. Deterministic: the same
// set gives the same bytes (padding is zero). A string that is not valid UTF-8 (a Latin-1 name)
// is written with U+FFFD for each byte that is not, as the JSON writer writes it.
std::vector<std::byte> WriteSphereSetBinary(const SphereSet& set,
                                            SphereSetBinaryContent content = SphereSetBinaryContent::kFull);

// A checked, read-only view of an encoded set (e.g. a memory mapping): every span points into the
// caller's bytes, which must stay alive and unchanged while the view is used. Open checks the
// header, checksum and structure (sizes, offsets, alignment, CSR offsets, zero padding, valid
// UTF-8), so every span can be read without leaving the buffer; the values (indices, finite
// numbers) are checked by ToSphereSet. O(file size); allocates only the source name.
class SphereSetBinaryView {
 public:
  // bytes.data() must be 16-byte aligned (a mapping, or new/malloc on x86-64): kInvalidArgument
  // otherwise. ReadSphereSetBinary accepts any address.
  static Result<SphereSetBinaryView> Open(std::span<const std::byte> bytes, std::string source_name = "<memory>");

  const std::string& source_name() const { return source_name_; }
  bool fast_only() const { return (flags_ & kSphereSetBinaryFlagFastOnly) != 0; }
  bool has_mesh() const { return (flags_ & kSphereSetBinaryFlagHasMesh) != 0; }
  size_t size() const { return sphere_count_; }
  size_t joint_count() const { return joint_count_; }
  size_t part_count() const { return part_count_; }
  uint32_t source_vertex_count() const { return source_vertex_count_; }
  uint32_t source_triangle_count() const { return source_triangle_count_; }
  size_t bind_count() const { return bind_count_; }

  std::string_view source_file() const { return String(0); }
  std::string_view params_json() const { return String(1); }
  std::string_view joint_name(size_t j) const { return String(2 + j); }                // j < joint_count()
  std::string_view part_name(size_t p) const { return String(2 + joint_count_ + p); }  // p < part_count()

  std::span<const int32_t> joint_parents() const { return Get<int32_t>(SphereSetSection::kJointParents); }
  std::span<const float> joint_rest_world() const { return Get<float>(SphereSetSection::kJointRestWorld); }
  std::span<const uint32_t> part_joint_offsets() const { return Get<uint32_t>(SphereSetSection::kPartJointOffsets); }
  std::span<const uint32_t> part_joints() const { return Get<uint32_t>(SphereSetSection::kPartJoints); }
  std::span<const float> centers_rest() const { return Get<float>(SphereSetSection::kCentersRest); }
  std::span<const float> radii_rest() const { return Get<float>(SphereSetSection::kRadiiRest); }
  std::span<const float> radii_fast() const { return Get<float>(SphereSetSection::kRadiiFast); }
  std::span<const uint16_t> sphere_part() const { return Get<uint16_t>(SphereSetSection::kSpherePart); }
  std::span<const uint16_t> sphere_joint() const { return Get<uint16_t>(SphereSetSection::kSphereJoint); }
  std::span<const uint16_t> sphere_level() const { return Get<uint16_t>(SphereSetSection::kSphereLevel); }
  std::span<const uint32_t> influence_offsets() const { return Get<uint32_t>(SphereSetSection::kInfluenceOffsets); }
  std::span<const uint16_t> influence_joints() const { return Get<uint16_t>(SphereSetSection::kInfluenceJoints); }
  std::span<const float> influence_weights() const { return Get<float>(SphereSetSection::kInfluenceWeights); }
  std::span<const uint32_t> excluded_pairs() const { return Get<uint32_t>(SphereSetSection::kExcludedPairs); }
  // Empty in a fast-only file.
  std::span<const uint32_t> vertex_offsets() const { return Get<uint32_t>(SphereSetSection::kVertexOffsets); }
  std::span<const uint32_t> vertices() const { return Get<uint32_t>(SphereSetSection::kVertices); }
  std::span<const uint32_t> triangle_offsets() const { return Get<uint32_t>(SphereSetSection::kTriangleOffsets); }
  std::span<const uint32_t> triangles() const { return Get<uint32_t>(SphereSetSection::kTriangles); }
  // Empty without a mesh.
  std::span<const uint32_t> triangle_vertices() const { return Get<uint32_t>(SphereSetSection::kTriangleVertices); }
  std::span<const float> positions_bind() const { return Get<float>(SphereSetSection::kPositionsBind); }
  std::span<const int32_t> bind_joints() const { return Get<int32_t>(SphereSetSection::kBindJoints); }
  std::span<const float> bind_inverse() const { return Get<float>(SphereSetSection::kBindInverse); }
  std::span<const uint32_t> mesh_influence_offsets() const {
    return Get<uint32_t>(SphereSetSection::kMeshInfluenceOffsets);
  }
  std::span<const uint16_t> mesh_influence_binds() const {
    return Get<uint16_t>(SphereSetSection::kMeshInfluenceBinds);
  }
  std::span<const float> mesh_influence_weights() const { return Get<float>(SphereSetSection::kMeshInfluenceWeights); }
  // Empty in a version-1 file and when the set has none.
  std::span<const float> influence_reach() const { return Get<float>(SphereSetSection::kInfluenceReach); }
  // Empty in a version-1 or 2 file and when the set has none.
  std::span<const float> fast_reference_inverse() const { return Get<float>(SphereSetSection::kFastReferenceInverse); }
  std::span<const float> fast_reference_spheres() const { return Get<float>(SphereSetSection::kFastReferenceSpheres); }
  std::span<const uint32_t> reach_group_offsets() const { return Get<uint32_t>(SphereSetSection::kReachGroupOffsets); }
  std::span<const float> reach_group_radii() const { return Get<float>(SphereSetSection::kReachGroupRadii); }
  std::span<const float> reach_group_weights() const { return Get<float>(SphereSetSection::kReachGroupWeights); }
  std::span<const uint32_t> piece_points() const { return Get<uint32_t>(SphereSetSection::kPiecePoints); }
  std::span<const uint32_t> piece_offsets() const { return Get<uint32_t>(SphereSetSection::kPieceOffsets); }
  std::span<const uint32_t> pieces() const { return Get<uint32_t>(SphereSetSection::kPieces); }
  std::span<const float> reach_group_blend() const { return Get<float>(SphereSetSection::kReachGroupBlend); }
  std::span<const float> reach_group_deviation() const { return Get<float>(SphereSetSection::kReachGroupDeviation); }
  // (rules, hops) and the rest gap: empty in a file before version 6.
  std::span<const uint32_t> contact_rules() const { return Get<uint32_t>(SphereSetSection::kContactRules); }
  std::span<const float> rest_gap() const { return Get<float>(SphereSetSection::kRestGap); }
  uint32_t version() const { return version_; }

  // Copies into a SphereSet (loaded_from = source_name()) and validates it (errors name the source).
  Result<SphereSet> ToSphereSet() const;

 private:
  friend struct SphereSetBinaryReader;  // sphere_set_binary_reader.cc: Open's steps
  struct Range {
    size_t offset = 0;  // bytes from the start
    size_t count = 0;   // elements
  };
  template <typename T>
  std::span<const T> Get(SphereSetSection id) const {
    const Range& r = sections_[static_cast<uint32_t>(id) - 1];
    return {reinterpret_cast<const T*>(bytes_.data() + r.offset), r.count};
  }
  std::string_view String(size_t k) const;

  std::span<const std::byte> bytes_;
  std::string source_name_;
  uint32_t version_ = 0;
  uint32_t flags_ = 0;
  uint32_t sphere_count_ = 0, joint_count_ = 0, part_count_ = 0;
  uint32_t source_vertex_count_ = 0, source_triangle_count_ = 0, bind_count_ = 0;
  Range sections_[kSphereSetSectionCount];
};

// Decodes a binary set at any address (copies first when misaligned); errors name source_name.
Result<SphereSet> ReadSphereSetBinary(std::span<const std::byte> bytes, const std::string& source_name = "<memory>");

// Files, hardened as LoadSphereSet/SaveSphereSet (sphere_set_io.h). Errors name the path.
// Saving checks every write through the close (file_io.h): a full disk is an error.
std::optional<Error> SaveSphereSetBinary(const SphereSet& set, const std::filesystem::path& path,
                                         SphereSetBinaryContent content = SphereSetBinaryContent::kFull);
Result<SphereSet> LoadSphereSetBinary(const std::filesystem::path& path);

// The whole of a sphere-set file (either format) in memory, in a 16-byte aligned buffer (what
// SphereSetBinaryView::Open wants). Only a regular file (a FIFO, device, socket or directory is
// refused without reading) of at most kMaxSphereSetBytes (sphere_set_io.h), refused from its
// size before anything is allocated; errors name the path (file_io.h: ReadRegularFile).
Result<std::vector<std::byte>> ReadSphereSetFile(const std::filesystem::path& path);

}  // namespace skinspheres::runtime
