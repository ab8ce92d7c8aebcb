// The binary sphere-set writer (sphere_set_binary.h): sections laid out, aligned and checksummed.
#include <algorithm>
#include <array>
#include <cstring>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

#include "format/binary_layout.h"
#include "format/utf8.h"
#include "skinspheres/runtime/format/file_io.h"
#include "skinspheres/runtime/format/sphere_set_binary.h"
#include "skinspheres/runtime/refit/mesh_bounds.h"

namespace skinspheres::runtime {

namespace {

using namespace internal;  // binary_layout.h, utf8.h

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

// The mesh sections: triangles, bind positions and entries, influences, grid points and pieces.
void AddMesh(const SphereSet& set, Writer& w) {
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

}  // namespace

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
  if (mesh) AddMesh(set, w);
  const uint32_t flags = (fast_only ? kSphereSetBinaryFlagFastOnly : 0u) | (mesh ? kSphereSetBinaryFlagHasMesh : 0u);
  return w.Finish(flags, {static_cast<uint32_t>(n), static_cast<uint32_t>(set.joint_count()),
                          static_cast<uint32_t>(set.parts.size()), set.source_vertex_count, set.source_triangle_count,
                          mesh ? static_cast<uint32_t>(set.mesh.binds.size()) : 0u});
}

std::optional<Error> SaveSphereSetBinary(const SphereSet& set, const std::filesystem::path& path,
                                         SphereSetBinaryContent content) {
  const std::vector<std::byte> bytes = WriteSphereSetBinary(set, content);
  // Checked through the close (file_io.h): a full disk is an error, never a truncated set.
  return WriteWholeFile(path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

}  // namespace skinspheres::runtime
