// Reading and writing a SphereSet as JSON (the versioned on-disk contract between the fitter
// and the runtime), and files in either format (JSON or binary, sphere_set_binary.h). Runtime code
// reads both without Assimp.
//
// {"format":"skinspheres.sphere_set","version":4,
//  "source":{"file","vertices","triangles"}, "params":{...},
//  "skeleton":{"joints":[{"name","parent","rest_world":[16 floats, column-major],
//                         "fast_reference_inverse":[16 floats, column-major]}]},
//  "parts":[{"name","joints":[joint indices]}],
//  "spheres":[{"id","part","joint","level","center":[x,y,z],"radius","radius_fast",
//              "vertices":[...],"triangles":[...],"influences":[[joint,weight],...],
//              "influence_reach":[one per influence],"fast_reference":[x,y,z,r],
//              "reach_groups":[[radius, one reach per influence(, one blend per influence,
//                               one deviation per influence)], ...],
//              "pieces":[triangle, level, index, ...]}],
//  "excluded_pairs":[[i,j,"same_joint"|"adjacent_joints"|"bind_overlap"],...],
//  "contact_rules":{"on":"triangles","hops":1,"rest_gap":0.018},
//  "mesh":{"triangles":[3 source vertex indices per source triangle],
//          "positions_bind":[x,y,z per source vertex],
//          "binds":[{"joint","inverse_bind":[16 floats, column-major]}],
//          "influence_offsets":[vertices + 1],"influence_binds":[...],"influence_weights":[...],
//          "piece_points":[triangle, level, i, j, ...]}}
// "contact_rules" is version 4 (sphere_set.h, narrow_phase/contact_rules.h: "on" "triangles" or
// "sphere_pairs", rule 2's hops, rule 3's rest gap in model units), written for every set whose rules
// are on triangles, with or without "mesh"; a file of versions 1 to 3 has none and reads as a set
// whose rules are on sphere pairs, which is written back as the version it came in (by content, as
// follows). "mesh" is version 2 (sphere_set.h); a version-1 file has none and is read as a set
// without a mesh; a set of rules on sphere pairs without a mesh is written as version 1. "influence_reach"
// (SphereSet::influence_reach) is optional in either version: every sphere has it or none does, and a file without it
// (written before it existed) reads as a set without reach, which fast refit computes from the mesh or takes as 1
// (sphere_set.h); it is written when the set has it. "fast_reference_inverse" (on every joint) with "fast_reference"
// (on every sphere), and "reach_groups" (on every sphere, 1 to 4 groups), are optional the same way: the fast refit's
// stored reference frame and reach groups (SphereSet::fast_reference_inverse, reach_group_offsets); a file without them
// refits with the rest pose and one group per sphere, and a reader that ignores them still refits soundly. A group row
// holds 1 + K numbers, or 1 + 3K with the groups' blends (SphereSet::reach_group_blend and reach_group_deviation), the
// same length in every row of a file; rows of 1 + K (files written before blends) read as a set without them. A reader
// older than blends refuses rows of 1 + 3K. "pieces" (on the spheres that own pieces of cut triangles) and
// "mesh.piece_points" are version 3 (triangle pieces, sphere_set.h; docs/TRIANGLE_PIECES.md), written only for a set
// that has them; version 1 and 2 files read as sets without pieces, and a version-2 file that names pieces is refused.
// Everything in the rest pose, in the source file's world space. Sphere "id" is its index.
// A reader refuses another format name, a newer version, a malformed or truncated file, or a set
// that fails SphereSet::Validate(), with a message naming the file and the problem.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>

#include "skinspheres/runtime/error.h"
#include "skinspheres/runtime/format/sphere_set.h"

namespace skinspheres::runtime {

std::string WriteSphereSetJson(const SphereSet& set);
Result<SphereSet> ReadSphereSetJson(std::string_view text, const std::string& source_name = "<memory>");

enum class SphereSetFileFormat : uint8_t {
  kJson,            // this file's format: the interchange and debugging format
  kBinary,          // sphere_set_binary.h, the whole set
  kBinaryFastOnly,  // sphere_set_binary.h, what fast refit reads
};
// By extension: ".json" -> kJson, ".ssb" -> kBinary; std::nullopt for anything else.
std::optional<SphereSetFileFormat> SphereSetFormatForPath(const std::filesystem::path& path);

// Either format, told apart by content (the binary magic number); errors name source_name.
Result<SphereSet> ReadSphereSet(std::span<const std::byte> bytes, const std::string& source_name = "<memory>");

// Files: errors name the path. Load reads either format (told apart by content) and sets
// loaded_from to the path. Save writes `format`, or without it the format of the extension (JSON
// when unknown); a fast-only set cannot be written as JSON (kInvalidArgument). Saving checks every
// write through the close (file_io.h), in both formats. Loading reads only a regular file (a FIFO
// or device is refused without reading) of at most kMaxSphereSetBytes, refused from its size
// before anything is allocated, in both formats; JSON nested deeper than kMaxJsonDepth (file_io.h)
// is refused before parsing. Reading JSON streams the spheres, pairs and mesh arrays out of the
// parsed document as they complete: it peaks at about the text plus the set (docs/LIMITS.md has
// the figures); reading binary peaks at the file plus the set.
inline constexpr uint64_t kMaxSphereSetBytes = uint64_t{512} << 20;  // 512 MiB
std::optional<Error> SaveSphereSet(const SphereSet& set, const std::filesystem::path& path);
std::optional<Error> SaveSphereSet(const SphereSet& set, const std::filesystem::path& path, SphereSetFileFormat format);
Result<SphereSet> LoadSphereSet(const std::filesystem::path& path);

}  // namespace skinspheres::runtime
