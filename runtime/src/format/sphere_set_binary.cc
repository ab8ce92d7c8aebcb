// The binary sphere-set asset (sphere_set_binary.h): writer, checked view, reader, files.
#include "skinspheres/runtime/format/sphere_set_binary.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstdio>
#include <cstring>
#include <initializer_list>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <utility>

#include "skinspheres/runtime/format/file_io.h"
#include "skinspheres/runtime/format/sphere_set_io.h"

namespace skinspheres::runtime {

static_assert(
    std::endian::native == std::endian::little,
    "the binary sphere-set layout is little-endian and read in place: big-endian hosts need a byte-swapping reader");
static_assert(sizeof(Mat4f) == 16 * sizeof(float) && sizeof(Eigen::Vector3f) == 3 * sizeof(float));

namespace {

// ---- XXH64 -------------------------------------------------------------------------------------

constexpr uint64_t kP1 = 0x9E3779B185EBCA87ull, kP2 = 0xC2B2AE3D27D4EB4Full, kP3 = 0x165667B19E3779F9ull,
                   kP4 = 0x85EBCA77C2B2AE63ull, kP5 = 0x27D4EB2F165667C5ull;

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
inline uint64_t Round(uint64_t acc, uint64_t input) { return std::rotl(acc + input * kP2, 31) * kP1; }
inline uint64_t Merge(uint64_t acc, uint64_t v) { return (acc ^ Round(0, v)) * kP1 + kP4; }

// ---- Layout ------------------------------------------------------------------------------------

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
constexpr std::array<SectionInfo, kSphereSetSectionCount> kSections = {{
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
bool SectionPresent(size_t id, uint32_t flags, uint32_t version) {
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

size_t AlignUp(size_t n) {
  return (n + kSphereSetBinaryAlignment - 1) / kSphereSetBinaryAlignment * kSphereSetBinaryAlignment;
}

// ---- Writer ------------------------------------------------------------------------------------

class Writer {
 public:
  // One section's bytes (copied when the file is assembled).
  template <typename T>
  void Add(SphereSetSection id, const T* data, size_t count) {
    static_assert(std::is_trivially_copyable_v<T>);
    Section& s = sections_[static_cast<size_t>(id) - 1];
    s.present = true;
    s.count = count;
    s.data = reinterpret_cast<const std::byte*>(data);
    s.bytes = count * sizeof(T);
  }
  template <typename T>
  void Add(SphereSetSection id, const std::vector<T>& v) {
    Add(id, v.data(), v.size());
  }
  // Owned data for sections that need re-packing.
  template <typename T>
  void AddOwned(SphereSetSection id, std::vector<T> v) {
    auto held = std::make_shared<std::vector<T>>(std::move(v));
    owned_.push_back(held);
    Add(id, held->data(), held->size());
  }

  std::vector<std::byte> Finish(uint32_t flags, const std::array<uint32_t, 6>& counts) {
    size_t section_count = 0;
    for (const Section& s : sections_) section_count += s.present;
    size_t at = AlignUp(kSphereSetBinaryHeaderSize + section_count * kSphereSetBinarySectionEntrySize);
    std::vector<size_t> offsets(kSphereSetSectionCount, 0);
    for (size_t k = 0; k < kSphereSetSectionCount; ++k) {
      if (!sections_[k].present) continue;
      offsets[k] = at;
      at = AlignUp(at + sections_[k].bytes);
    }
    std::vector<std::byte> out(at, std::byte{0});
    std::memcpy(out.data(), kSphereSetBinaryMagic, 8);
    Put32(out, kVersionAt, kSphereSetBinaryVersion);
    Put32(out, kFlagsAt, flags);
    Put64(out, kFileSizeAt, out.size());
    Put32(out, kSectionCountAt, static_cast<uint32_t>(section_count));
    const size_t count_at[6] = {kSphereCountAt, kJointCountAt,    kPartCountAt,
                                kVertexCountAt, kTriangleCountAt, kBindCountAt};
    for (size_t k = 0; k < 6; ++k) Put32(out, count_at[k], counts[k]);
    size_t entry = kSphereSetBinaryHeaderSize;
    for (size_t k = 0; k < kSphereSetSectionCount; ++k) {
      const Section& s = sections_[k];
      if (!s.present) continue;
      Put32(out, entry, static_cast<uint32_t>(k + 1));
      Put32(out, entry + 4, kSections[k].element_size);
      Put64(out, entry + 8, offsets[k]);
      Put64(out, entry + 16, s.count);
      entry += kSphereSetBinarySectionEntrySize;
      if (s.bytes) std::memcpy(out.data() + offsets[k], s.data, s.bytes);
    }
    Put64(out, kChecksumAt, Xxh64(std::span<const std::byte>(out).subspan(kChecksummedFrom)));
    return out;
  }

 private:
  struct Section {
    bool present = false;
    size_t count = 0, bytes = 0;
    const std::byte* data = nullptr;
  };
  static void Put32(std::vector<std::byte>& out, size_t at, uint32_t v) { std::memcpy(out.data() + at, &v, 4); }
  static void Put64(std::vector<std::byte>& out, size_t at, uint64_t v) { std::memcpy(out.data() + at, &v, 8); }

  std::array<Section, kSphereSetSectionCount> sections_{};
  std::vector<std::shared_ptr<void>> owned_;
};

// ---- Reader ------------------------------------------------------------------------------------

Error Refuse(const std::string& source, const std::string& what, ErrorCode code = ErrorCode::kInvalidData) {
  return MakeError(code, OneLine(source + ": " + what));
}

// CSR offsets: first 0 (when any), never decreasing, last == total.
bool CsrOffsetsOk(std::span<const uint32_t> offsets, size_t total) {
  if (offsets.empty()) return total == 0;
  if (offsets.front() != 0 || offsets.back() != total) return false;
  for (size_t k = 1; k < offsets.size(); ++k) {
    if (offsets[k] < offsets[k - 1]) return false;
  }
  return true;
}

// The UTF-8 sequence at s[k]: {length, valid}. An invalid one's length is its maximal subpart
// (the lead byte and the continuation bytes that fit it, at least 1), which gets one U+FFFD.
// Shortest forms only, no surrogates, nothing above U+10FFFF.
std::pair<size_t, bool> Utf8Sequence(std::string_view s, size_t k) {
  const auto byte = [&](size_t i) { return static_cast<unsigned char>(s[i]); };
  const unsigned char c = byte(k);
  size_t len = 0;
  unsigned char lo = 0x80, hi = 0xBF;  // the range of the second byte
  if (c < 0x80) return {1, true};
  if (c >= 0xC2 && c <= 0xDF)
    len = 2;
  else if (c >= 0xE0 && c <= 0xEF)
    len = 3, lo = c == 0xE0 ? 0xA0 : 0x80, hi = c == 0xED ? 0x9F : 0xBF;
  else if (c >= 0xF0 && c <= 0xF4)
    len = 4, lo = c == 0xF0 ? 0x90 : 0x80, hi = c == 0xF4 ? 0x8F : 0xBF;
  else
    return {1, false};
  for (size_t i = 1; i < len; ++i) {
    const bool fits = k + i < s.size() && byte(k + i) >= (i == 1 ? lo : 0x80) && byte(k + i) <= (i == 1 ? hi : 0xBF);
    if (!fits) return {i, false};
  }
  return {len, true};
}

// The length of the valid UTF-8 prefix of s (s.size() when all of it is valid).
size_t ValidUtf8Prefix(std::string_view s) {
  size_t k = 0;
  for (std::pair<size_t, bool> seq; k < s.size() && (seq = Utf8Sequence(s, k)).second;) k += seq.first;
  return k;
}

// s with each invalid sequence replaced by U+FFFD (names taken from a file's bytes: a path, a
// Latin-1 FBX name), as the JSON writer (nlohmann::json's error_handler_t::replace) does.
std::string ValidUtf8(std::string_view s) {
  if (ValidUtf8Prefix(s) == s.size()) return std::string(s);
  std::string out;
  for (size_t k = 0; k < s.size();) {
    const auto [length, valid] = Utf8Sequence(s, k);
    if (valid)
      out.append(s.substr(k, length));
    else
      out += "\xEF\xBF\xBD";
    k += length;
  }
  return out;
}

template <typename Dst, typename Src>
void CopyInto(std::vector<Dst>& dst, std::span<const Src> src) {
  dst.assign(src.begin(), src.end());
}

// n elements of `floats_per` floats each (Mat4f, Vector3f: plain float arrays) from a float span.
template <typename T>
void CopyFloats(std::vector<T>& dst, std::span<const float> src, size_t floats_per) {
  dst.resize(src.size() / floats_per);
  if (!src.empty()) std::memcpy(static_cast<void*>(dst.data()->data()), src.data(), src.size() * sizeof(float));
}

}  // namespace

uint64_t Xxh64(std::span<const std::byte> data, uint64_t seed) {
  const std::byte* p = data.data();
  const std::byte* const end = p + data.size();
  uint64_t h;
  if (data.size() >= 32) {
    uint64_t v1 = seed + kP1 + kP2, v2 = seed + kP2, v3 = seed, v4 = seed - kP1;
    const std::byte* const limit = end - 32;
    do {
      v1 = Round(v1, Load64(p));
      v2 = Round(v2, Load64(p + 8));
      v3 = Round(v3, Load64(p + 16));
      v4 = Round(v4, Load64(p + 24));
      p += 32;
    } while (p <= limit);
    h = std::rotl(v1, 1) + std::rotl(v2, 7) + std::rotl(v3, 12) + std::rotl(v4, 18);
    h = Merge(Merge(Merge(Merge(h, v1), v2), v3), v4);
  } else {
    h = seed + kP5;
  }
  h += data.size();
  for (; p + 8 <= end; p += 8) h = std::rotl(h ^ Round(0, Load64(p)), 27) * kP1 + kP4;
  if (p + 4 <= end) {
    h = std::rotl(h ^ (static_cast<uint64_t>(Load32(p)) * kP1), 23) * kP2 + kP3;
    p += 4;
  }
  for (; p < end; ++p) h = std::rotl(h ^ (static_cast<uint64_t>(*p) * kP5), 11) * kP1;
  h ^= h >> 33;
  h *= kP2;
  h ^= h >> 29;
  h *= kP3;
  h ^= h >> 32;
  return h;
}

bool IsSphereSetBinary(std::span<const std::byte> data) {
  return data.size() >= 8 && std::memcmp(data.data(), kSphereSetBinaryMagic, 8) == 0;
}

std::vector<std::byte> WriteSphereSetBinary(const SphereSet& set, SphereSetBinaryContent content) {
  const bool fast_only = set.fast_only || content == SphereSetBinaryContent::kFastOnly;
  const bool mesh = !fast_only && set.has_mesh();
  const size_t n = set.size();
  Writer w;

  std::vector<uint32_t> string_offsets = {0};
  std::string strings;
  auto add_string = [&](const std::string& s) {
    strings += ValidUtf8(s);  // the reader refuses invalid UTF-8
    string_offsets.push_back(static_cast<uint32_t>(strings.size()));
  };
  add_string(set.source_file);
  add_string(set.params_json);
  for (const std::string& name : set.joint_names) add_string(name);
  for (const SpherePart& part : set.parts) add_string(part.name);
  std::vector<uint32_t> part_offsets = {0}, part_joints;
  for (const SpherePart& part : set.parts) {
    part_joints.insert(part_joints.end(), part.joints.begin(), part.joints.end());
    part_offsets.push_back(static_cast<uint32_t>(part_joints.size()));
  }
  std::vector<uint32_t> pairs;
  pairs.reserve(3 * set.excluded_pairs.size());
  for (const ExcludedPair& p : set.excluded_pairs)
    pairs.insert(pairs.end(), {p.i, p.j, static_cast<uint32_t>(p.reason)});

  w.AddOwned(SphereSetSection::kStringOffsets, std::move(string_offsets));
  w.AddOwned(SphereSetSection::kStringBytes, std::vector<char>(strings.begin(), strings.end()));
  w.Add(SphereSetSection::kJointParents, set.joint_parents);
  w.Add(SphereSetSection::kJointRestWorld, set.joint_rest_world.empty() ? nullptr : set.joint_rest_world.data()->data(),
        16 * set.joint_rest_world.size());
  w.AddOwned(SphereSetSection::kPartJointOffsets, std::move(part_offsets));
  w.AddOwned(SphereSetSection::kPartJoints, std::move(part_joints));
  w.Add(SphereSetSection::kCentersRest, n ? set.centers_rest.data()->data() : nullptr, 3 * n);
  w.Add(SphereSetSection::kRadiiRest, set.radii_rest);
  w.Add(SphereSetSection::kRadiiFast, set.radii_fast);
  w.Add(SphereSetSection::kSpherePart, set.sphere_part);
  w.Add(SphereSetSection::kSphereJoint, set.sphere_joint);
  w.Add(SphereSetSection::kSphereLevel, set.sphere_level);
  w.Add(SphereSetSection::kInfluenceOffsets, set.influence_offsets);
  w.Add(SphereSetSection::kInfluenceJoints, set.influence_joints);
  w.Add(SphereSetSection::kInfluenceWeights, set.influence_weights);
  w.AddOwned(SphereSetSection::kExcludedPairs, std::move(pairs));
  if (!fast_only) {
    w.Add(SphereSetSection::kVertexOffsets, set.vertex_offsets);
    w.Add(SphereSetSection::kVertices, set.vertices);
    w.Add(SphereSetSection::kTriangleOffsets, set.triangle_offsets);
    w.Add(SphereSetSection::kTriangles, set.triangles);
  }
  // The fast-only variant keeps the mesh's reach when the set has no reach of its own: its reader
  // has no mesh to compute it from (sphere_set.h). Only from a sound set (the mesh's indices are
  // read); an unsound one is written as it is, and its reader refuses it.
  std::vector<float> reach_from_mesh;
  if (fast_only && set.influence_reach.empty() && set.has_mesh() && !set.Validate()) {
    if (auto reach = InfluenceReachFromMesh(set); reach.ok()) reach_from_mesh = std::move(*reach);
  }
  w.Add(SphereSetSection::kInfluenceReach, reach_from_mesh.empty() ? set.influence_reach : reach_from_mesh);
  w.Add(SphereSetSection::kFastReferenceInverse,
        set.fast_reference_inverse.empty() ? nullptr : set.fast_reference_inverse.data()->data(),
        16 * set.fast_reference_inverse.size());
  w.Add(SphereSetSection::kFastReferenceSpheres,
        set.fast_reference_spheres.empty() ? nullptr : set.fast_reference_spheres.data()->data(),
        4 * set.fast_reference_spheres.size());
  w.Add(SphereSetSection::kReachGroupOffsets, set.reach_group_offsets);
  w.Add(SphereSetSection::kReachGroupRadii, set.reach_group_radii);
  w.Add(SphereSetSection::kReachGroupWeights, set.reach_group_weights);
  w.Add(SphereSetSection::kReachGroupBlend, set.reach_group_blend);
  w.Add(SphereSetSection::kReachGroupDeviation, set.reach_group_deviation);
  w.AddOwned(SphereSetSection::kContactRules,
             std::vector<uint32_t>{static_cast<uint32_t>(set.contact_rules), set.contact_hops});
  w.AddOwned(SphereSetSection::kRestGap, std::vector<float>{set.rest_gap});
  if (mesh) {
    const skinning::SkinnedMesh& m = set.mesh;
    std::vector<int32_t> bind_joints;
    std::vector<float> bind_inverse;
    bind_joints.reserve(m.binds.size());
    bind_inverse.reserve(16 * m.binds.size());
    for (const skinning::BindEntry& b : m.binds) {
      bind_joints.push_back(b.joint);
      bind_inverse.insert(bind_inverse.end(), b.inverse_bind.data(), b.inverse_bind.data() + 16);
    }
    w.Add(SphereSetSection::kTriangleVertices, set.triangle_vertices);
    w.Add(SphereSetSection::kPositionsBind, m.positions_bind.empty() ? nullptr : m.positions_bind.data()->data(),
          3 * m.positions_bind.size());
    w.AddOwned(SphereSetSection::kBindJoints, std::move(bind_joints));
    w.AddOwned(SphereSetSection::kBindInverse, std::move(bind_inverse));
    w.Add(SphereSetSection::kMeshInfluenceOffsets, m.influence_offsets);
    w.Add(SphereSetSection::kMeshInfluenceBinds, m.influence_binds);
    std::vector<uint32_t> points, pieces;
    points.reserve(2 * set.piece_points.size());
    for (const PiecePoint& g : set.piece_points)
      points.insert(points.end(), {g.triangle, uint32_t{g.level} << 16 | uint32_t{g.i} << 8 | g.j});
    pieces.reserve(2 * set.pieces.size());
    for (const TrianglePiece& p : set.pieces)
      pieces.insert(pieces.end(), {p.triangle, uint32_t{p.level} << 16 | p.index});
    w.AddOwned(SphereSetSection::kPiecePoints, std::move(points));
    w.Add(SphereSetSection::kPieceOffsets, set.piece_offsets);
    w.AddOwned(SphereSetSection::kPieces, std::move(pieces));
    w.Add(SphereSetSection::kMeshInfluenceWeights, m.influence_weights);
  }
  const uint32_t flags = (fast_only ? kSphereSetBinaryFlagFastOnly : 0u) | (mesh ? kSphereSetBinaryFlagHasMesh : 0u);
  return w.Finish(flags, {static_cast<uint32_t>(n), static_cast<uint32_t>(set.joint_count()),
                          static_cast<uint32_t>(set.parts.size()), set.source_vertex_count, set.source_triangle_count,
                          mesh ? static_cast<uint32_t>(set.mesh.binds.size()) : 0u});
}

// Open's steps, in order, each refusing with a message naming the source (Refuse).
struct SphereSetBinaryReader {
  // Alignment, magic, header size, layout version, file size, checksum.
  static std::optional<Error> CheckFile(std::span<const std::byte> bytes, const std::string& src) {
    if (reinterpret_cast<uintptr_t>(bytes.data()) % kSphereSetBinaryAlignment != 0) {
      return Refuse(src, "the buffer is not 16-byte aligned (map the file, or use ReadSphereSetBinary)",
                    ErrorCode::kInvalidArgument);
    }
    if (!IsSphereSetBinary(bytes)) {
      return Refuse(src,
                    bytes.size() < 8 ? "not a binary sphere set (shorter than its magic number)"
                                     : "not a binary sphere set (wrong magic number)",
                    ErrorCode::kFormatRejected);
    }
    if (bytes.size() < kSphereSetBinaryHeaderSize) {
      return Refuse(src, "truncated: " + std::to_string(bytes.size()) + " bytes, the header alone takes 64");
    }
    const std::byte* base = bytes.data();
    const uint32_t version = Load32(base + kVersionAt);
    if (version < kSphereSetBinaryVersionWithoutReach || version > kSphereSetBinaryVersion) {
      return Refuse(src,
                    "layout version " + std::to_string(version) + " is not supported (this build reads versions " +
                        std::to_string(kSphereSetBinaryVersionWithoutReach) + " to " +
                        std::to_string(kSphereSetBinaryVersion) + ")",
                    ErrorCode::kVersionMismatch);
    }
    const uint64_t file_size = Load64(base + kFileSizeAt);
    if (file_size > bytes.size()) {
      return Refuse(src, "truncated: " + std::to_string(bytes.size()) + " of " + std::to_string(file_size) + " bytes");
    }
    if (file_size < bytes.size()) {
      return Refuse(src, std::to_string(bytes.size() - file_size) + " bytes after the end of the set (" +
                             std::to_string(file_size) + " bytes)");
    }
    if (Xxh64(bytes.subspan(kChecksummedFrom)) != Load64(base + kChecksumAt)) {
      return Refuse(src, "checksum mismatch: the file is corrupted");
    }

    return std::nullopt;
  }

  // The header's counts and flags into v.
  static std::optional<Error> ReadHeader(SphereSetBinaryView& v, const std::string& src) {
    const std::byte* base = v.bytes_.data();
    v.version_ = Load32(base + kVersionAt);
    v.flags_ = Load32(base + kFlagsAt);
    v.sphere_count_ = Load32(base + kSphereCountAt);
    v.joint_count_ = Load32(base + kJointCountAt);
    v.part_count_ = Load32(base + kPartCountAt);
    v.source_vertex_count_ = Load32(base + kVertexCountAt);
    v.source_triangle_count_ = Load32(base + kTriangleCountAt);
    v.bind_count_ = Load32(base + kBindCountAt);
    if ((v.flags_ & ~(kSphereSetBinaryFlagFastOnly | kSphereSetBinaryFlagHasMesh)) != 0 ||
        (v.fast_only() && v.has_mesh())) {
      return Refuse(src, "unknown or contradictory flags " + std::to_string(v.flags_));
    }
    if (!v.has_mesh() && v.bind_count_ != 0) return Refuse(src, "bind entries without a mesh");
    if (Load32(base + 60) != 0) return Refuse(src, "reserved header field is not 0");

    return std::nullopt;
  }

  // The section table: ids ascending, exactly those the flags call for, each inside the file.
  // *table_end: where the table ends.
  static std::optional<Error> ReadSections(SphereSetBinaryView& v, const std::string& src, uint64_t* table_end_out) {
    const std::byte* base = v.bytes_.data();
    const uint64_t file_size = v.bytes_.size();
    const uint32_t version = v.version_;
    const uint64_t section_count = Load32(base + kSectionCountAt);
    const uint64_t table_end = kSphereSetBinaryHeaderSize + section_count * kSphereSetBinarySectionEntrySize;
    if (section_count > kSphereSetSectionCount || table_end > file_size) {
      return Refuse(src, "section table of " + std::to_string(section_count) + " entries does not fit");
    }
    uint64_t previous_end = table_end;
    uint32_t previous_id = 0;
    for (uint64_t k = 0; k < section_count; ++k) {
      const std::byte* e = base + kSphereSetBinaryHeaderSize + k * kSphereSetBinarySectionEntrySize;
      const uint32_t id = Load32(e), element_size = Load32(e + 4);
      const uint64_t offset = Load64(e + 8), count = Load64(e + 16);
      if (id == 0 || id > kSphereSetSectionCount) return Refuse(src, "unknown section id " + std::to_string(id));
      const SectionInfo& info = kSections[id - 1];
      const std::string name = std::string("section ") + info.name;
      if (id <= previous_id) return Refuse(src, name + " is out of order or repeated");
      if (!SectionPresent(id, v.flags_, version)) {
        return Refuse(src, name + " is not expected with these flags in layout version " + std::to_string(version));
      }
      for (uint32_t missing = previous_id + 1; missing < id; ++missing) {
        if (SectionPresent(missing, v.flags_, version))
          return Refuse(src, std::string("section ") + kSections[missing - 1].name + " is missing");
      }
      previous_id = id;
      if (element_size != info.element_size) {
        return Refuse(src, name + " has elements of " + std::to_string(element_size) + " bytes, expected " +
                               std::to_string(info.element_size));
      }
      if (offset % kSphereSetBinaryAlignment != 0)
        return Refuse(src, name + " offset " + std::to_string(offset) + " is not 16-byte aligned");
      if (offset < previous_end || offset > file_size || count > (file_size - offset) / element_size) {
        return Refuse(src, name + " (offset " + std::to_string(offset) + ", " + std::to_string(count) +
                               " elements) overlaps another or runs past the end of the file");
      }
      previous_end = offset + count * element_size;
      v.sections_[id - 1] = {static_cast<size_t>(offset), static_cast<size_t>(count)};
    }
    for (uint32_t missing = previous_id + 1; missing <= kSphereSetSectionCount; ++missing) {
      if (SectionPresent(missing, v.flags_, version))
        return Refuse(src, std::string("section ") + kSections[missing - 1].name + " is missing");
    }

    *table_end_out = table_end;
    return std::nullopt;
  }

  // Counts: every section's length follows from the header counts and the CSR offsets.
  static std::optional<Error> CheckCounts(SphereSetBinaryView& v, const std::string& src) {
    const uint64_t n = v.sphere_count_, joints = v.joint_count_, parts = v.part_count_;
    auto count_is = [&](SphereSetSection id, uint64_t expected) -> std::optional<Error> {
      const size_t got = v.sections_[static_cast<uint32_t>(id) - 1].count;
      if (got == expected) return std::nullopt;
      return Refuse(src, std::string("section ") + kSections[static_cast<uint32_t>(id) - 1].name + " has " +
                             std::to_string(got) + " elements, expected " + std::to_string(expected));
    };
    auto csr = [&](SphereSetSection offsets_id, uint64_t rows,
                   std::initializer_list<SphereSetSection> lists) -> std::optional<Error> {
      if (auto err = count_is(offsets_id, rows + 1)) return err;
      const auto offsets = v.Get<uint32_t>(offsets_id);
      for (SphereSetSection list : lists) {
        if (!CsrOffsetsOk(offsets, v.sections_[static_cast<uint32_t>(list) - 1].count)) {
          return Refuse(src, std::string("section ") + kSections[static_cast<uint32_t>(offsets_id) - 1].name +
                                 " does not start at 0, decreases, or does not end at the length of section " +
                                 kSections[static_cast<uint32_t>(list) - 1].name);
        }
      }
      return std::nullopt;
    };
    using S = SphereSetSection;
    const uint64_t strings = 2 + joints + parts;
    std::optional<Error> err;
    if ((err = csr(S::kStringOffsets, strings, {S::kStringBytes})) || (err = count_is(S::kJointParents, joints)) ||
        (err = count_is(S::kJointRestWorld, 16 * joints)) ||
        (err = csr(S::kPartJointOffsets, parts, {S::kPartJoints})) || (err = count_is(S::kCentersRest, 3 * n)) ||
        (err = count_is(S::kRadiiRest, n)) || (err = count_is(S::kRadiiFast, n)) ||
        (err = count_is(S::kSpherePart, n)) || (err = count_is(S::kSphereJoint, n)) ||
        (err = count_is(S::kSphereLevel, n)) ||
        (err = csr(S::kInfluenceOffsets, n, {S::kInfluenceJoints, S::kInfluenceWeights}))) {
      return *err;
    }
    const size_t reach = v.sections_[static_cast<uint32_t>(S::kInfluenceReach) - 1].count;
    const size_t influences = v.sections_[static_cast<uint32_t>(S::kInfluenceJoints) - 1].count;
    if (reach != 0 && reach != influences) {
      return Refuse(src, "section influence_reach has " + std::to_string(reach) + " elements, expected " +
                             std::to_string(influences) + " (one per influence) or 0");
    }
    const size_t ref_inverse = v.sections_[static_cast<uint32_t>(S::kFastReferenceInverse) - 1].count;
    const size_t ref_spheres = v.sections_[static_cast<uint32_t>(S::kFastReferenceSpheres) - 1].count;
    if (!(ref_inverse == 0 && ref_spheres == 0) && !(ref_inverse == 16 * joints && ref_spheres == 4 * n)) {
      return Refuse(src, "sections fast_reference_inverse and fast_reference_spheres have " +
                             std::to_string(ref_inverse) + " and " + std::to_string(ref_spheres) +
                             " elements, expected " + std::to_string(16 * joints) + " and " + std::to_string(4 * n) +
                             " (one per joint and per sphere) or both 0");
    }
    // Reach groups: none, or offsets per sphere over the radii (their sizes and the weights' count
    // are SphereSet::Validate()'s, from the values).
    const size_t group_offsets = v.sections_[static_cast<uint32_t>(S::kReachGroupOffsets) - 1].count;
    if (group_offsets == 0) {
      if (v.sections_[static_cast<uint32_t>(S::kReachGroupRadii) - 1].count != 0 ||
          v.sections_[static_cast<uint32_t>(S::kReachGroupWeights) - 1].count != 0) {
        return Refuse(src, "sections reach_group_radii and reach_group_weights are given without reach_group_offsets");
      }
    } else if ((err = csr(S::kReachGroupOffsets, n, {S::kReachGroupRadii}))) {
      return *err;
    }
    // The groups' blends: both as long as the reaches (SphereSet::Validate()), or both empty.
    const size_t blends = v.sections_[static_cast<uint32_t>(S::kReachGroupBlend) - 1].count;
    const size_t deviations = v.sections_[static_cast<uint32_t>(S::kReachGroupDeviation) - 1].count;
    const size_t reaches = v.sections_[static_cast<uint32_t>(S::kReachGroupWeights) - 1].count;
    if (!(blends == 0 && deviations == 0) && !(blends == reaches && deviations == reaches)) {
      return Refuse(src, "sections reach_group_blend and reach_group_deviation have " + std::to_string(blends) +
                             " and " + std::to_string(deviations) + " elements, expected " + std::to_string(reaches) +
                             " (one per group and influence, as reach_group_weights) or both 0");
    }
    // The contact rules: (rules, hops) and the gap, in a file that has them.
    if (v.version_ >= kSphereSetBinaryVersion) {
      if ((err = count_is(S::kContactRules, 2)) || (err = count_is(S::kRestGap, 1))) return *err;
    }
    // Pieces: pairs of u32; offsets per sphere over them, or none with no pieces (their values are
    // SphereSet::Validate()'s).
    const size_t piece_offsets = v.sections_[static_cast<uint32_t>(S::kPieceOffsets) - 1].count;
    const size_t pieces = v.sections_[static_cast<uint32_t>(S::kPieces) - 1].count;
    if (v.sections_[static_cast<uint32_t>(S::kPiecePoints) - 1].count % 2 != 0 || pieces % 2 != 0) {
      return Refuse(src, "section piece_points or pieces does not hold whole pairs");
    }
    if (piece_offsets == 0 ? pieces != 0 : piece_offsets != n + 1) {
      return Refuse(src, "section piece_offsets has " + std::to_string(piece_offsets) + " elements, expected " +
                             std::to_string(n + 1) + " (or 0 with no pieces)");
    }
    if (piece_offsets != 0 && !CsrOffsetsOk(v.piece_offsets(), pieces / 2)) {
      return Refuse(src,
                    "section piece_offsets does not start at 0, decreases, or does not end at the number of pieces");
    }
    if (v.sections_[static_cast<uint32_t>(S::kExcludedPairs) - 1].count % 3 != 0) {
      return Refuse(src, "section excluded_pairs does not hold whole (i, j, reason) triples");
    }
    if (!v.fast_only() &&
        ((err = csr(S::kVertexOffsets, n, {S::kVertices})) || (err = csr(S::kTriangleOffsets, n, {S::kTriangles})))) {
      return *err;
    }
    if (v.has_mesh()) {
      const uint64_t vertices = v.source_vertex_count_;
      if ((err = count_is(S::kTriangleVertices, 3 * uint64_t{v.source_triangle_count_})) ||
          (err = count_is(S::kPositionsBind, 3 * vertices)) || (err = count_is(S::kBindJoints, v.bind_count_)) ||
          (err = count_is(S::kBindInverse, 16 * uint64_t{v.bind_count_})) ||
          (err = csr(S::kMeshInfluenceOffsets, vertices, {S::kMeshInfluenceBinds, S::kMeshInfluenceWeights}))) {
        return *err;
      }
    }
    return std::nullopt;
  }

  // The bytes between the table and the sections, and after the last, are zero (so a set has one
  // encoding and reads back byte for byte).
  static std::optional<Error> CheckPadding(const SphereSetBinaryView& v, const std::string& src, uint64_t table_end) {
    const std::byte* base = v.bytes_.data();
    const uint64_t file_size = v.bytes_.size();
    const uint32_t version = v.version_;
    uint64_t covered = table_end;
    for (size_t k = 0; k <= kSphereSetSectionCount; ++k) {
      const bool last = k == kSphereSetSectionCount;
      if (!last && !SectionPresent(k + 1, v.flags_, version)) continue;
      const uint64_t start = last ? file_size : v.sections_[k].offset;
      for (uint64_t at = covered; at < start; ++at) {
        if (base[at] != std::byte{0}) return Refuse(src, "padding byte at offset " + std::to_string(at) + " is not 0");
      }
      if (!last) covered = start + uint64_t{v.sections_[k].count} * kSections[k].element_size;
    }
    return std::nullopt;
  }

  // Every string is valid UTF-8.
  static std::optional<Error> CheckStrings(const SphereSetBinaryView& v, const std::string& src) {
    const uint64_t joints = v.joint_count_, parts = v.part_count_;
    const uint64_t strings = 2 + joints + parts;
    for (size_t k = 0; k < strings; ++k) {
      const std::string_view text = v.String(k);
      const size_t valid = ValidUtf8Prefix(text);
      if (valid == text.size()) continue;
      const std::string which = k == 0           ? std::string("source_file")
                                : k == 1         ? std::string("params")
                                : k < 2 + joints ? "joint " + std::to_string(k - 2) + "'s name"
                                                 : "part " + std::to_string(k - 2 - joints) + "'s name";
      return Refuse(src, which + " is not valid UTF-8 (byte " + std::to_string(valid) + ")");
    }
    return std::nullopt;
  }
};

Result<SphereSetBinaryView> SphereSetBinaryView::Open(std::span<const std::byte> bytes, std::string source_name) {
  using Reader = SphereSetBinaryReader;
  const std::string& src = source_name;
  if (auto err = Reader::CheckFile(bytes, src)) return *err;
  SphereSetBinaryView v;
  v.bytes_ = bytes;
  uint64_t table_end = 0;
  if (auto err = Reader::ReadHeader(v, src)) return *err;
  if (auto err = Reader::ReadSections(v, src, &table_end)) return *err;
  if (auto err = Reader::CheckCounts(v, src)) return *err;
  if (auto err = Reader::CheckPadding(v, src, table_end)) return *err;
  if (auto err = Reader::CheckStrings(v, src)) return *err;
  v.source_name_ = std::move(source_name);
  return v;
}

std::string_view SphereSetBinaryView::String(size_t k) const {
  const auto offsets = Get<uint32_t>(SphereSetSection::kStringOffsets);
  const auto chars = Get<char>(SphereSetSection::kStringBytes);
  return std::string_view(chars.data() + offsets[k], offsets[k + 1] - offsets[k]);
}

Result<SphereSet> SphereSetBinaryView::ToSphereSet() const {
  SphereSet set;
  const size_t n = sphere_count_;
  set.loaded_from = source_name_;
  set.source_file = source_file();
  // The fit's settings become the JSON's "params" object (convert): what the JSON reader would
  // accept, i.e. empty or an object nested at most kMaxJsonDepth deep (copying and writing a deeper
  // document recurses past the stack), kept in the form the JSON reader gives (compact).
  if (const std::string_view params = params_json(); !params.empty()) {
    if (const size_t depth = ScanJson(params).depth; depth > kMaxJsonDepth) {
      return Refuse(source_name_, "the fit settings (params) nest " + std::to_string(depth) + " deep (at most " +
                                      std::to_string(kMaxJsonDepth) + " is read)");
    }
    const nlohmann::json parsed = nlohmann::json::parse(params, nullptr, /*allow_exceptions=*/false);
    if (!parsed.is_object()) return Refuse(source_name_, "the fit settings (params) are not a JSON object");
    set.params_json = parsed.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  }
  set.source_vertex_count = source_vertex_count_;
  set.source_triangle_count = source_triangle_count_;
  set.joint_names.reserve(joint_count_);
  for (size_t j = 0; j < joint_count_; ++j) set.joint_names.emplace_back(joint_name(j));
  CopyInto(set.joint_parents, joint_parents());
  CopyFloats(set.joint_rest_world, joint_rest_world(), 16);
  set.parts.resize(part_count_);
  const auto part_offsets = part_joint_offsets();
  const auto all_part_joints = part_joints();
  for (size_t p = 0; p < part_count_; ++p) {
    set.parts[p].name = part_name(p);
    set.parts[p].joints.assign(all_part_joints.begin() + part_offsets[p],
                               all_part_joints.begin() + part_offsets[p + 1]);
  }
  CopyFloats(set.centers_rest, centers_rest(), 3);
  CopyInto(set.radii_rest, radii_rest());
  CopyInto(set.radii_fast, radii_fast());
  CopyInto(set.sphere_part, sphere_part());
  CopyInto(set.sphere_joint, sphere_joint());
  CopyInto(set.sphere_level, sphere_level());
  CopyInto(set.influence_offsets, influence_offsets());
  CopyInto(set.influence_joints, influence_joints());
  CopyInto(set.influence_weights, influence_weights());
  CopyInto(set.influence_reach, influence_reach());
  CopyFloats(set.fast_reference_inverse, fast_reference_inverse(), 16);
  CopyFloats(set.fast_reference_spheres, fast_reference_spheres(), 4);
  CopyInto(set.reach_group_offsets, reach_group_offsets());
  CopyInto(set.reach_group_radii, reach_group_radii());
  CopyInto(set.reach_group_weights, reach_group_weights());
  CopyInto(set.reach_group_blend, reach_group_blend());
  CopyInto(set.reach_group_deviation, reach_group_deviation());
  // The contact rules (version 6); a file before them states its rules on sphere pairs.
  set.contact_rules = ContactRules::kSpherePairs;
  set.contact_hops = 0;
  set.rest_gap = 0.0f;
  if (version_ >= kSphereSetBinaryVersion) {
    const auto rules = contact_rules();
    if (rules[0] > static_cast<uint32_t>(ContactRules::kTriangles)) {
      return Refuse(source_name_, "unknown contact rules " + std::to_string(rules[0]));
    }
    set.contact_rules = static_cast<ContactRules>(rules[0]);
    set.contact_hops = rules[1];
    set.rest_gap = rest_gap()[0];
  }
  const auto pairs = excluded_pairs();
  set.excluded_pairs.resize(pairs.size() / 3);
  for (size_t k = 0; k < set.excluded_pairs.size(); ++k) {
    const uint32_t reason = pairs[3 * k + 2];
    if (reason > static_cast<uint32_t>(ExclusionReason::kBindOverlap)) {
      return Refuse(source_name_,
                    "excluded pair " + std::to_string(k) + " has unknown reason " + std::to_string(reason));
    }
    set.excluded_pairs[k] = {pairs[3 * k], pairs[3 * k + 1], static_cast<ExclusionReason>(reason)};
  }
  if (fast_only()) {
    set.fast_only = true;
    set.vertex_offsets.assign(n + 1, 0);
    set.triangle_offsets.assign(n + 1, 0);
  } else {
    CopyInto(set.vertex_offsets, vertex_offsets());
    CopyInto(set.vertices, vertices());
    CopyInto(set.triangle_offsets, triangle_offsets());
    CopyInto(set.triangles, triangles());
  }
  if (has_mesh()) {
    CopyInto(set.triangle_vertices, triangle_vertices());
    skinning::SkinnedMesh& m = set.mesh;
    CopyFloats(m.positions_bind, positions_bind(), 3);
    m.binds.resize(bind_count_);
    const auto joints = bind_joints();
    const auto inverse = bind_inverse();
    for (size_t b = 0; b < bind_count_; ++b) {
      m.binds[b].joint = joints[b];
      std::memcpy(m.binds[b].inverse_bind.data(), inverse.data() + 16 * b, 16 * sizeof(float));
    }
    CopyInto(m.influence_offsets, mesh_influence_offsets());
    CopyInto(m.influence_binds, mesh_influence_binds());
    CopyInto(m.influence_weights, mesh_influence_weights());
    const auto points = piece_points();
    set.piece_points.resize(points.size() / 2);
    for (size_t k = 0; k < set.piece_points.size(); ++k) {
      const uint32_t code = points[2 * k + 1];
      if (code >> 24 != 0) return Refuse(source_name_, "grid point " + std::to_string(k) + " has a level beyond 255");
      set.piece_points[k] = {points[2 * k], static_cast<uint16_t>(code >> 16), static_cast<uint8_t>(code >> 8),
                             static_cast<uint8_t>(code)};
    }
    CopyInto(set.piece_offsets, piece_offsets());
    const auto pieces_read = pieces();
    set.pieces.resize(pieces_read.size() / 2);
    for (size_t k = 0; k < set.pieces.size(); ++k) {
      const uint32_t code = pieces_read[2 * k + 1];
      set.pieces[k] = {pieces_read[2 * k], static_cast<uint16_t>(code >> 16), static_cast<uint16_t>(code)};
    }
  }
  if (auto err = set.Validate()) return Refuse(source_name_, err->message);
  return set;
}

Result<SphereSet> ReadSphereSetBinary(std::span<const std::byte> bytes, const std::string& source_name) {
  std::vector<std::byte> aligned;
  if (reinterpret_cast<uintptr_t>(bytes.data()) % kSphereSetBinaryAlignment != 0) {
    aligned.assign(bytes.begin(), bytes.end());  // operator new aligns to 16 on every supported target
    bytes = aligned;
  }
  auto view = SphereSetBinaryView::Open(bytes, source_name);
  if (!view.ok()) return view.error();
  return view->ToSphereSet();
}

Result<std::vector<std::byte>> ReadSphereSetFile(const std::filesystem::path& path) {
  return ReadRegularFileBytes(path, kMaxSphereSetBytes, "sphere set");
}

std::optional<Error> SaveSphereSetBinary(const SphereSet& set, const std::filesystem::path& path,
                                         SphereSetBinaryContent content) {
  const std::vector<std::byte> bytes = WriteSphereSetBinary(set, content);
  // Checked through the close (file_io.h): a full disk is an error, never a truncated set.
  return WriteWholeFile(path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

Result<SphereSet> LoadSphereSetBinary(const std::filesystem::path& path) {
  auto bytes = ReadSphereSetFile(path);
  if (!bytes.ok()) return bytes.error();
  return ReadSphereSetBinary(*bytes, PathText(path));
}

}  // namespace skinspheres::runtime
