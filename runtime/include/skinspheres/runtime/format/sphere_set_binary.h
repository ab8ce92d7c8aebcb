// The binary sphere-set asset (".ssb"): the whole SphereSet (sphere_set.h), mesh included, in a
// little-endian layout that loads without parsing and can be memory-mapped. JSON (sphere_set_io.h)
// stays the interchange and debugging format; both hold the same set, and converting one into the
// other and back is bit-exact (`skinspheres convert`).
//
// Layout, version 6 (version 5, the same without sections 39-40, version 4, without 37-40, version 3,
// without 34-40, version 2, without 29-40, and version 1, without 28-40, are still read). Every integer and
// float is little-endian; offsets count bytes from the start of the file (never pointers), so the
// file works at any address.
//
//   offset size  header (64 bytes)
//     0     8    magic 89 53 53 42 0D 0A 1A 0A ("\x89SSB\r\n\x1a\n": a high bit, CR LF and ^Z
//                catch 7-bit and text-mode transfers)
//     8     8    u64 checksum: XXH64, seed 0 (Xxh64 below; xxhsum -H1 computes the same), of the
//                bytes [16, file_size)
//    16     4    u32 layout version (kSphereSetBinaryVersion; every version before it reads too)
//    20     4    u32 flags: bit 0 fast-only, bit 1 has a mesh (never both); other bits 0
//    24     8    u64 file_size: the file's exact length
//    32     4    u32 section_count
//    36     4    u32 sphere_count N
//    40     4    u32 joint_count J
//    44     4    u32 part_count P
//    48     4    u32 source_vertex_count V
//    52     4    u32 source_triangle_count T
//    56     4    u32 bind_count B (mesh bind entries; 0 without a mesh)
//    60     4    u32 reserved, 0
//   64: the section table, section_count entries of 24 bytes:
//     0     4    u32 id (SphereSetSection), ascending, each at most once
//     4     4    u32 element_size in bytes (fixed per id, below)
//     8     8    u64 offset: a multiple of 16, after the table and after the previous section
//    16     8    u64 count of elements
//   then the sections, each starting on a 16-byte boundary, zero padding between them. Every array
//   is plain (float, u32, u16, i32), naturally aligned, read in place.
//
//   id  section                 type  count            what (sphere_set.h)
//    1  string_offsets          u32   S + 1            S = 2 + J + P strings: source_file,
//    2  string_bytes            u8    string_offsets[S]   params_json (a JSON object or empty),
//                                                       joint names, part names
//                                                       (UTF-8, no terminator)
//    3  joint_parents           i32   J
//    4  joint_rest_world        f32   16 J             column-major 4x4 per joint
//    5  part_joint_offsets      u32   P + 1            CSR: part p lists part_joints[o[p], o[p+1])
//    6  part_joints             u32   o[P]
//    7  centers_rest            f32   3 N              xyz per sphere
//    8  radii_rest              f32   N
//    9  radii_fast              f32   N
//   10  sphere_part             u16   N
//   11  sphere_joint            u16   N
//   12  sphere_level            u16   N
//   13  influence_offsets       u32   N + 1            CSR over 14, 15
//   14  influence_joints        u16   o[N]
//   15  influence_weights       f32   o[N]
//   16  excluded_pairs          u32   3 E              (i, j, reason) per pair, reason: 0 same joint,
//                                                       1 adjacent joints, 2 bind overlap
//   17  vertex_offsets          u32   N + 1            CSR over 18         } not in a fast-only
//   18  vertices                u32   o[N]                                 } file
//   19  triangle_offsets        u32   N + 1            CSR over 20         }
//   20  triangles               u32   o[N]                                 }
//   21  triangle_vertices       u32   3 T              mesh (flag bit 1 only)
//   22  positions_bind          f32   3 V
//   23  bind_joints             i32   B
//   24  bind_inverse            f32   16 B             column-major 4x4 per bind entry
//   25  mesh_influence_offsets  u32   V + 1            CSR over 26, 27
//   26  mesh_influence_binds    u16   o[V]
//   27  mesh_influence_weights  f32   o[V]
//   28  influence_reach         f32   o[N] or 0        per entry of 14 (version 2, every file; 0
//                                                       elements: the set has none, sphere_set.h)
//   29  fast_reference_inverse  f32   16 J or 0        column-major 4x4 per joint } version 3, every
//   30  fast_reference_spheres  f32   4 N or 0         (x, y, z, r) per sphere    } file; both 0: the
//                                                       rest pose (sphere_set.h, refit_job.h)
//   31  reach_group_offsets     u32   N + 1 or 0       CSR over 32            } version 3, every
//   32  reach_group_radii       f32   o[N]             per group              } file; all 0: one
//   33  reach_group_weights     f32   sum of groups    per group, one per     } group per sphere
//                                     x influences     influence of 14           (sphere_set.h)
//   34  piece_points            u32   2 G              (triangle, level << 16 | i << 8 | j) per } version 4,
//                                                       grid point (SphereSet::piece_points)   } with a mesh
//   35  piece_offsets           u32   N + 1 or 0       CSR over 36; 0: no pieces              } (flag bit
//   36  pieces                  u32   2 o[N]           (triangle, level << 16 | index) each   } 1) only
//   37  reach_group_blend       f32   as 33 or 0       per group and influence } version 5, every
//   38  reach_group_deviation   f32   as 33 or 0       per group and influence } file; both 0: none
//                                                       (sphere_set.h, refit_job.h "Group blends")
//   39  contact_rules           u32   2                (rules: 0 sphere pairs, 1 triangles; hops) } version 6,
//   40  rest_gap                f32   1                model units (contact_rules.h, rule 3)   } every file
// A file holds exactly the sections its flags and version call for. A change of layout bumps the
// version. A version-1 file reads as a set without influence reach, a version-1 or 2 file as one
// without a fast reference (the rest pose) or reach groups, a file before version 4 as one without
// triangle pieces, a file before version 5 as one without the groups' blends, a file before version 6
// as one whose contact rules are on sphere pairs (ContactRules::kSpherePairs).
//
// Fast-only variant: sections 17-27 and 34-36 left out, i.e. everything fast refit never reads (Xbot: 18 KB
// instead of 1.6 MB; its JSON takes 3.5 MB). It keeps sections 28-33 and 37-40, 28 filled from the mesh when the set
// has a mesh and no reach of its own (a fast-only set has no mesh to compute it from later), so it
// refits exactly as the whole set does. A set read from it has SphereSet::fast_only set; exact refit and
// triangle tests refuse it with an error saying so.
//
// Reading refuses, with one line "<source>: <problem>", a wrong magic (kFormatRejected), another
// layout version (kVersionMismatch), a truncated or over-long file, a checksum mismatch, and every
// structural fault (section ids, sizes, offsets, alignment, counts that disagree with the header,
// CSR offsets that decrease or overrun) with kInvalidData; nothing is allocated before the sizes
// are known to fit inside the input. ToSphereSet then refuses what the JSON reader would: params
// (the fit settings) that are neither empty nor a JSON object nested at most kMaxJsonDepth
// (file_io.h) deep (kept compact, as the JSON reader gives them), and a set that fails
// SphereSet::Validate().
//
// Memory-mapping: map the file (mmap / MapViewOfFile: page-aligned) and open a SphereSetBinaryView
// on it; the view's spans point into the mapping. ReadSphereSetBinary copies into a SphereSet
// (what CharacterAsset takes), a few memcpy calls. A big-endian host does not compile this file.
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

// A checked, read-only view of an encoded set: every span points into the caller's bytes, which
// must stay alive and unchanged while the view is used. Open checks the header, the checksum and
// the structure (sizes, offsets, alignment, CSR offsets, zero padding, strings that are valid
// UTF-8), so every span and CSR list can be read
// without leaving the buffer; the values themselves (indices into other arrays, finite numbers)
// are checked by ToSphereSet (SphereSet::Validate). O(file size) for the checksum, O(spheres +
// strings) for the rest; allocates only the source name.
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
