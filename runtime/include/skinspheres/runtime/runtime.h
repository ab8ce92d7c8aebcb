// The runtime, stage by stage: what an engine links to find, every frame, which parts of an
// animated character touch or pass through each other. One folder per stage, in src/ and include/
// alike; this header includes them all, in the order a frame runs them.
//
//   format/        takes a file or bytes; gives a SphereSet (sphere_set.h) from JSON
//                  (sphere_set_io.h) or the binary .ssb (sphere_set_binary.h), read in place or
//                  copied; file_io.h reads only regular files, capped, on POSIX and Windows.
//   refit/         takes the set, G_j(t) per joint and (exact mode) skinned positions; gives one
//                  sphere per set sphere that holds its triangles this frame (refit_job.h).
//   broad_phase/   takes the refitted spheres and a PairFilter (pair_filter.h: the pairs a character
//                  can never avoid); gives the sphere pairs that overlap, sorted, with depth and
//                  parts (broad_phase.h: a candidate cache, SIMD kernels per instruction set, the
//                  all-pairs oracle).
//   narrow_phase/  takes the sphere pairs and the skinned mesh (or joint matrices: it skins what it
//                  tests); gives the triangle pairs that intersect or come within a margin, grouped
//                  by body-part pair, with a penetration depth (narrow_phase.h; triangle_contact.h
//                  is the exact triangle test).
//   api/           the engine API over those stages: CharacterAsset (shared, read-only) and
//                  CharacterInstance (per character on screen), joint mapping by name
//                  (character.h, joint_mapping.h).
//   crowd/         many instances at once through a ParallelFor, or an engine's own loop (crowd.h).
//
// error.h: Result<T> and Error, the error idiom every stage (and the offline fitter) uses at set-up;
// per-frame calls never allocate or throw and return bool or a FrameStatus.
// Platforms: skinspheres/skinning/platform.h; docs/PLATFORMS.md.
#pragma once

// clang-format off: in stage order
#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/api/joint_mapping.h"
#include "skinspheres/runtime/broad_phase/broad_phase.h"
#include "skinspheres/runtime/broad_phase/pair_filter.h"
#include "skinspheres/runtime/crowd/crowd.h"
#include "skinspheres/runtime/error.h"
#include "skinspheres/runtime/format/file_io.h"
#include "skinspheres/runtime/format/sphere_set.h"
#include "skinspheres/runtime/format/sphere_set_binary.h"
#include "skinspheres/runtime/format/sphere_set_io.h"
#include "skinspheres/runtime/narrow_phase/narrow_phase.h"
#include "skinspheres/runtime/narrow_phase/triangle_contact.h"
#include "skinspheres/runtime/refit/refit_job.h"
// clang-format on
