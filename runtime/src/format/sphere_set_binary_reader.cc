// The binary sphere-set reader (sphere_set_binary.h): the checked view over a file's bytes, the
// set it converts to, and files.
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

#include "format/binary_layout.h"
#include "format/utf8.h"
#include "skinspheres/runtime/format/file_io.h"
#include "skinspheres/runtime/format/json_shape.h"
#include "skinspheres/runtime/format/sphere_set_binary.h"
#include "skinspheres/runtime/format/sphere_set_io.h"
#include "skinspheres/runtime/refit/mesh_bounds.h"

namespace skinspheres::runtime {

namespace {

using namespace internal;  // binary_layout.h, utf8.h

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

bool IsSphereSetBinary(std::span<const std::byte> data) {
  return data.size() >= 8 && std::memcmp(data.data(), kSphereSetBinaryMagic, 8) == 0;
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

  // Section `id` holds `expected` elements, else the error naming it.
  static std::optional<Error> CountIs(const SphereSetBinaryView& v, const std::string& src, SphereSetSection id,
                                      uint64_t expected) {
    const size_t got = v.sections_[static_cast<uint32_t>(id) - 1].count;
    if (got == expected) return std::nullopt;
    return Refuse(src, std::string("section ") + kSections[static_cast<uint32_t>(id) - 1].name + " has " +
                           std::to_string(got) + " elements, expected " + std::to_string(expected));
  }

  // Section `offsets_id` holds rows + 1 CSR offsets over each of `lists`.
  static std::optional<Error> Csr(const SphereSetBinaryView& v, const std::string& src, SphereSetSection offsets_id,
                                  uint64_t rows, std::initializer_list<SphereSetSection> lists) {
    if (auto err = CountIs(v, src, offsets_id, rows + 1)) return err;
    const auto offsets = v.Get<uint32_t>(offsets_id);
    for (SphereSetSection list : lists) {
      if (!CsrOffsetsOk(offsets, v.sections_[static_cast<uint32_t>(list) - 1].count)) {
        return Refuse(src, std::string("section ") + kSections[static_cast<uint32_t>(offsets_id) - 1].name +
                               " does not start at 0, decreases, or does not end at the length of section " +
                               kSections[static_cast<uint32_t>(list) - 1].name);
      }
    }
    return std::nullopt;
  }

  static size_t Count(const SphereSetBinaryView& v, SphereSetSection id) {
    return v.sections_[static_cast<uint32_t>(id) - 1].count;
  }

  // Counts: every section's length follows from the header counts and the CSR offsets.
  static std::optional<Error> CheckCounts(SphereSetBinaryView& v, const std::string& src) {
    const uint64_t n = v.sphere_count_, joints = v.joint_count_, parts = v.part_count_;
    using S = SphereSetSection;
    const uint64_t strings = 2 + joints + parts;
    std::optional<Error> err;
    if ((err = Csr(v, src, S::kStringOffsets, strings, {S::kStringBytes})) ||
        (err = CountIs(v, src, S::kJointParents, joints)) || (err = CountIs(v, src, S::kJointRestWorld, 16 * joints)) ||
        (err = Csr(v, src, S::kPartJointOffsets, parts, {S::kPartJoints})) ||
        (err = CountIs(v, src, S::kCentersRest, 3 * n)) || (err = CountIs(v, src, S::kRadiiRest, n)) ||
        (err = CountIs(v, src, S::kRadiiFast, n)) || (err = CountIs(v, src, S::kSpherePart, n)) ||
        (err = CountIs(v, src, S::kSphereJoint, n)) || (err = CountIs(v, src, S::kSphereLevel, n)) ||
        (err = Csr(v, src, S::kInfluenceOffsets, n, {S::kInfluenceJoints, S::kInfluenceWeights}))) {
      return *err;
    }
    if ((err = CheckFastSectionCounts(v, src))) return *err;
    // The contact rules: (rules, hops) and the gap, in a file that has them.
    if (v.version_ >= kSphereSetBinaryVersion) {
      if ((err = CountIs(v, src, S::kContactRules, 2)) || (err = CountIs(v, src, S::kRestGap, 1))) return *err;
    }
    if ((err = CheckPieceCounts(v, src))) return *err;
    if (Count(v, S::kExcludedPairs) % 3 != 0) {
      return Refuse(src, "section excluded_pairs does not hold whole (i, j, reason) triples");
    }
    if (!v.fast_only() && ((err = Csr(v, src, S::kVertexOffsets, n, {S::kVertices})) ||
                           (err = Csr(v, src, S::kTriangleOffsets, n, {S::kTriangles})))) {
      return *err;
    }
    if (v.has_mesh()) {
      const uint64_t vertices = v.source_vertex_count_;
      if ((err = CountIs(v, src, S::kTriangleVertices, 3 * uint64_t{v.source_triangle_count_})) ||
          (err = CountIs(v, src, S::kPositionsBind, 3 * vertices)) ||
          (err = CountIs(v, src, S::kBindJoints, v.bind_count_)) ||
          (err = CountIs(v, src, S::kBindInverse, 16 * uint64_t{v.bind_count_})) ||
          (err = Csr(v, src, S::kMeshInfluenceOffsets, vertices, {S::kMeshInfluenceBinds, S::kMeshInfluenceWeights}))) {
        return *err;
      }
    }
    return std::nullopt;
  }

  // What fast refit reads beyond the spheres: the influences' reach, the fast reference, the reach
  // groups and their blends, each present in full or absent.
  static std::optional<Error> CheckFastSectionCounts(const SphereSetBinaryView& v, const std::string& src) {
    using S = SphereSetSection;
    const uint64_t n = v.sphere_count_, joints = v.joint_count_;
    const size_t reach = Count(v, S::kInfluenceReach), influences = Count(v, S::kInfluenceJoints);
    if (reach != 0 && reach != influences) {
      return Refuse(src, "section influence_reach has " + std::to_string(reach) + " elements, expected " +
                             std::to_string(influences) + " (one per influence) or 0");
    }
    const size_t ref_inverse = Count(v, S::kFastReferenceInverse), ref_spheres = Count(v, S::kFastReferenceSpheres);
    if (!(ref_inverse == 0 && ref_spheres == 0) && !(ref_inverse == 16 * joints && ref_spheres == 4 * n)) {
      return Refuse(src, "sections fast_reference_inverse and fast_reference_spheres have " +
                             std::to_string(ref_inverse) + " and " + std::to_string(ref_spheres) +
                             " elements, expected " + std::to_string(16 * joints) + " and " + std::to_string(4 * n) +
                             " (one per joint and per sphere) or both 0");
    }
    // Reach groups: none, or offsets per sphere over the radii (their sizes and the weights' count
    // are SphereSet::Validate()'s, from the values).
    if (Count(v, S::kReachGroupOffsets) == 0) {
      if (Count(v, S::kReachGroupRadii) != 0 || Count(v, S::kReachGroupWeights) != 0) {
        return Refuse(src, "sections reach_group_radii and reach_group_weights are given without reach_group_offsets");
      }
    } else if (auto err = Csr(v, src, S::kReachGroupOffsets, n, {S::kReachGroupRadii})) {
      return err;
    }
    // The groups' blends: both as long as the reaches (SphereSet::Validate()), or both empty.
    const size_t blends = Count(v, S::kReachGroupBlend), deviations = Count(v, S::kReachGroupDeviation);
    const size_t reaches = Count(v, S::kReachGroupWeights);
    if (!(blends == 0 && deviations == 0) && !(blends == reaches && deviations == reaches)) {
      return Refuse(src, "sections reach_group_blend and reach_group_deviation have " + std::to_string(blends) +
                             " and " + std::to_string(deviations) + " elements, expected " + std::to_string(reaches) +
                             " (one per group and influence, as reach_group_weights) or both 0");
    }
    return std::nullopt;
  }

  // Pieces: pairs of u32; offsets per sphere over them, or none with no pieces (their values are
  // SphereSet::Validate()'s).
  static std::optional<Error> CheckPieceCounts(const SphereSetBinaryView& v, const std::string& src) {
    using S = SphereSetSection;
    const uint64_t n = v.sphere_count_;
    const size_t piece_offsets = Count(v, S::kPieceOffsets), pieces = Count(v, S::kPieces);
    if (Count(v, S::kPiecePoints) % 2 != 0 || pieces % 2 != 0) {
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
  // The mesh sections (has_mesh()) into set: triangles, bind positions, bind entries, influences,
  // grid points and pieces.
  static std::optional<Error> MeshInto(const SphereSetBinaryView& v, SphereSet* set) {
    CopyInto(set->triangle_vertices, v.triangle_vertices());
    skinning::SkinnedMesh& m = set->mesh;
    CopyFloats(m.positions_bind, v.positions_bind(), 3);
    m.binds.resize(v.bind_count_);
    const auto joints = v.bind_joints();
    const auto inverse = v.bind_inverse();
    for (size_t b = 0; b < v.bind_count_; ++b) {
      m.binds[b].joint = joints[b];
      std::memcpy(m.binds[b].inverse_bind.data(), inverse.data() + 16 * b, 16 * sizeof(float));
    }
    CopyInto(m.influence_offsets, v.mesh_influence_offsets());
    CopyInto(m.influence_binds, v.mesh_influence_binds());
    CopyInto(m.influence_weights, v.mesh_influence_weights());
    const auto points = v.piece_points();
    set->piece_points.resize(points.size() / 2);
    for (size_t k = 0; k < set->piece_points.size(); ++k) {
      const uint32_t code = points[2 * k + 1];
      if (code >> 24 != 0) return Refuse(v.source_name_, "grid point " + std::to_string(k) + " has a level beyond 255");
      set->piece_points[k] = {points[2 * k], static_cast<uint16_t>(code >> 16), static_cast<uint8_t>(code >> 8),
                              static_cast<uint8_t>(code)};
    }
    CopyInto(set->piece_offsets, v.piece_offsets());
    const auto pieces_read = v.pieces();
    set->pieces.resize(pieces_read.size() / 2);
    for (size_t k = 0; k < set->pieces.size(); ++k) {
      const uint32_t code = pieces_read[2 * k + 1];
      set->pieces[k] = {pieces_read[2 * k], static_cast<uint16_t>(code >> 16), static_cast<uint16_t>(code)};
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
    if (auto err = SphereSetBinaryReader::MeshInto(*this, &set)) return *err;
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

Result<SphereSet> LoadSphereSetBinary(const std::filesystem::path& path) {
  auto bytes = ReadSphereSetFile(path);
  if (!bytes.ok()) return bytes.error();
  return ReadSphereSetBinary(*bytes, PathText(path));
}

}  // namespace skinspheres::runtime
