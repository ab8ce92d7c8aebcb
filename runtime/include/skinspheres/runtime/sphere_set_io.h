// Reading and writing a SphereSet as JSON (the versioned on-disk contract between the fitter
// and the runtime). Runtime code reads it without Assimp.
//
// {"format":"skinspheres.sphere_set","version":2,
//  "source":{"file","vertices","triangles"}, "params":{...},
//  "skeleton":{"joints":[{"name","parent","rest_world":[16 floats, column-major]}]},
//  "parts":[{"name","joints":[joint indices]}],
//  "spheres":[{"id","part","joint","level","center":[x,y,z],"radius","radius_fast",
//              "vertices":[...],"triangles":[...],"influences":[[joint,weight],...]}],
//  "excluded_pairs":[[i,j,"same_joint"|"adjacent_joints"|"bind_overlap"],...],
//  "mesh":{"triangles":[3 source vertex indices per source triangle],
//          "positions_bind":[x,y,z per source vertex],
//          "binds":[{"joint","inverse_bind":[16 floats, column-major]}],
//          "influence_offsets":[vertices + 1],"influence_binds":[...],"influence_weights":[...]}}
// "mesh" is version 2 (sphere_set.h); a version-1 file has none and is read as a set without a
// mesh; a set without a mesh is written as version 1.
// Everything in the rest pose, in the source file's world space. Sphere "id" is its index.
// A reader refuses another format name, a newer version, a malformed or truncated file, or a set
// that fails SphereSet::Validate(), with a message naming the file and the problem.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include "skinspheres/runtime/error.h"
#include "skinspheres/runtime/sphere_set.h"

namespace skinspheres::runtime {

std::string WriteSphereSetJson(const SphereSet& set);
Result<SphereSet> ReadSphereSetJson(std::string_view text, const std::string& source_name = "<memory>");

// Files: errors name the path. Saving checks every write through the close. Loading reads only a
// regular file (a FIFO or device is refused without reading) of at most kMaxSphereSetBytes,
// refused from its size; JSON nested deeper than kMaxJsonDepth (file_io.h) is refused before
// parsing. Reading streams the spheres, pairs and mesh arrays out of the parsed document as they
// complete: it peaks at about the text plus the set (docs/LIMITS.md has the figures).
inline constexpr uint64_t kMaxSphereSetBytes = uint64_t{512} << 20;  // 512 MiB
std::optional<Error> SaveSphereSet(const SphereSet& set, const std::filesystem::path& path);
Result<SphereSet> LoadSphereSet(const std::filesystem::path& path);

}  // namespace skinspheres::runtime
