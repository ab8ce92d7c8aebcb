/* skinspheres.h: the C API of the skinspheres runtime (C99), for engines and for bindings
   (C# P/Invoke, Godot GDExtension, Rust, Python ctypes). Only C types cross it: opaque handles,
   fixed-size integers, floats, and caller-owned arrays. The library is a shared library
   (libskinspheres_c.so, target skinspheres::c) that exports nothing but these functions.

   Use:
     skinspheres_asset* asset;                 set-up: load once (binary .ssb or JSON), share
     if (skinspheres_asset_load_file("xbot.ssb", &asset) != SKINSPHERES_OK)
       fail(skinspheres_last_error());         one line naming the file and the problem
     skinspheres_instance* inst;               one per character on screen; joint matrices in the
     skinspheres_instance_create(asset, my_joint_names, my_joint_count, &inst);   engine's order
     each frame:
       skinspheres_instance_update_fast(inst, joint_world, my_joint_count);   16 floats per joint
       size_t n;
       skinspheres_instance_find_sphere_pairs(inst, &n);                                  count first,
       skinspheres_instance_get_sphere_pairs(inst, buffer, capacity, &n);         then fill
       size_t parts, triangles;                                               the triangles behind them:
       skinspheres_instance_find_contacts(inst, NULL, 0, &parts, &triangles); count first,
       skinspheres_instance_get_part_contacts(inst, part_buf, part_cap, &parts);      then fill
       skinspheres_instance_get_triangle_contacts(inst, SKINSPHERES_ALL_PART_PAIRS, tri_buf, tri_cap,
                                                  &triangles);
     skinspheres_instance_destroy(inst); skinspheres_asset_release(asset);

   Matrices: 16 floats per joint, column-major (OpenGL / glTF order: the translation in elements
   12, 13, 14), affine (the last row is ignored), one world (model) transform G_j per joint, all in
   one frame: the spheres come out in that frame. Positions: 3 floats (x, y, z) per vertex,
   tightly packed, indexed like the source file's vertices. Other layouts (row-major, transposed,
   interleaved, padded, negative strides: numpy's views) go through the *_strided calls, which give
   the same results, bit for bit, as the packed calls on the same values.

   Errors: every call that can fail returns a skinspheres_status; skinspheres_last_error() then
   gives one line saying why (the file and the problem at set-up), until the next failing call on
   the same thread or skinspheres_clear_last_error(). Per-frame calls never allocate for it.

   Lifetimes: every pointer a call returns says how long it stays valid. In short: static strings
   (version, status strings, skinspheres_instance_status's message) for the program's life; the
   asset's names and rest matrices while the asset lives (a reference of the caller's, of an
   instance's, or of skinspheres_asset_retain's); an instance's sphere pairs and spheres until its
   next update, find or destroy; skinspheres_last_error()'s text until the next failing call on the
   thread or skinspheres_clear_last_error().

   Caller buffers: every skinspheres_*_get_* call (and skinspheres_asset_sphere_joints) that copies
   into a caller's buffer of `capacity` entries sets *out_count to the TOTAL number of entries, also
   when it returns SKINSPHERES_BUFFER_TOO_SMALL (having copied the first `capacity`): allocate
   *out_count entries and call again (0.3.0; in 0.2 it was the number copied).

   Threads: an asset is immutable once loaded and may be used by any number of threads and
   instances. An instance is used by one thread at a time; distinct instances may be updated and
   queried concurrently (skinspheres_crowd_update_and_find_sphere_pairs does it for you).

   Allocation, in full in docs/EMBEDDING.md: loading and creating allocate; per frame, a contact
   buffer grows the first time a frame needs more room than any before
   (skinspheres_instance_reserve_contacts pins them at set-up), the first
   skinspheres_instance_find_contacts sizes the narrow phase's scratch unless
   skinspheres_instance_reserve_contacts did, and the first one without positions its
   skinned-position buffer; an instance's first strided call with a layout other than the packed
   one sizes its gather buffer for that input (joint matrices: 64 bytes per joint it reads;
   positions: 12 bytes per vertex of the asset; the crowd's strided calls do it on the calling
   thread, before the loop); nothing else.

   Queries follow one pattern: a call computes and gives the count (skinspheres_instance_find_sphere_pairs for
   the overlapping spheres, skinspheres_instance_find_contacts for the triangles behind them); a
   skinspheres_instance_get_* call copies into the caller's buffer (or a pointer call reads the
   sphere pairs in place). */
#ifndef SKINSPHERES_SKINSPHERES_H_
#define SKINSPHERES_SKINSPHERES_H_

#include <stddef.h>
#include <stdint.h>

#include "skinspheres/version.h"

#if defined(_WIN32)
#if defined(SKINSPHERES_C_BUILDING)
#define SKINSPHERES_C_API __declspec(dllexport)
#else
#define SKINSPHERES_C_API __declspec(dllimport)
#endif
#else
#define SKINSPHERES_C_API __attribute__((visibility("default")))
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* Status of a call. 1-9 are the C++ API's ErrorCode values. */
typedef enum skinspheres_status {
  SKINSPHERES_OK = 0,
  SKINSPHERES_FILE_NOT_FOUND = 1,
  SKINSPHERES_FILE_UNREADABLE = 2,
  SKINSPHERES_FORMAT_REJECTED = 3, /* not a sphere set (neither binary nor JSON) */
  SKINSPHERES_INVALID_DATA = 4,    /* read, but corrupt or inconsistent; or non-finite frame input */
  SKINSPHERES_VERSION_MISMATCH = 5,
  SKINSPHERES_MISMATCHED_ASSET = 6, /* the set was fitted on another character (joints, vertices) */
  SKINSPHERES_INVALID_ARGUMENT = 7, /* null handle, short array, exact mode on a fast-only set, ... */
  SKINSPHERES_NOT_FOUND = 8,
  SKINSPHERES_CHECK_FAILED = 9,
  SKINSPHERES_BUFFER_TOO_SMALL = 100, /* the caller's buffer holds fewer entries than the count */
  SKINSPHERES_OUT_OF_MEMORY = 101,
  SKINSPHERES_INTERNAL_ERROR = 102
} skinspheres_status;

typedef enum skinspheres_refit_mode {
  SKINSPHERES_MODE_EXACT = 0, /* from skinned vertex positions: tight spheres */
  SKINSPHERES_MODE_FAST = 1   /* from joint matrices alone: no skinning, looser spheres */
} skinspheres_refit_mode;

/* One sphere pair of the broad phase: spheres sphere_i < sphere_j overlap by depth (>= 0, the
   set's units); part_i, part_j are their body parts (skinspheres_asset_part_name). 16 bytes. The
   triangles behind them that really touch are the contacts (skinspheres_instance_find_contacts). */
typedef struct skinspheres_sphere_pair {
  uint32_t sphere_i;
  uint32_t sphere_j;
  float depth;
  uint16_t part_i;
  uint16_t part_j;
} skinspheres_sphere_pair;

typedef struct skinspheres_asset skinspheres_asset;       /* a loaded sphere set, shared */
typedef struct skinspheres_instance skinspheres_instance; /* one character's per-frame state */

/* ---- Version and errors ---- */

/* The linked library's SKINSPHERES_VERSION (MAJOR * 10000 + MINOR * 100 + PATCH) and string (a
   static string, valid for the program's life). */
SKINSPHERES_C_API int skinspheres_version(void);
SKINSPHERES_C_API const char* skinspheres_version_string(void);
/* "ok", "file not found", ..., "buffer too small": a static string (valid for the program's life). */
SKINSPHERES_C_API const char* skinspheres_status_string(skinspheres_status status);
/* The message of the last failing call on this thread ("" when none): one line, never NULL. Valid
   until the next failing call on this thread or skinspheres_clear_last_error() (copy it to keep
   it). A call that succeeds leaves it as it was. */
SKINSPHERES_C_API const char* skinspheres_last_error(void);
/* Forgets this thread's last error: skinspheres_last_error() gives "" until the next failing call. */
SKINSPHERES_C_API void skinspheres_clear_last_error(void);

/* ---- Assets ---- */

/* Loads a sphere set, binary or JSON (told apart by content). path: UTF-8, on every platform
   (Windows too). Errors name the path. */
SKINSPHERES_C_API skinspheres_status skinspheres_asset_load_file(const char* path, skinspheres_asset** out_asset);
/* The same from memory (copied: the caller may free data on return); name is used in messages
   (NULL: "<memory>"). */
SKINSPHERES_C_API skinspheres_status skinspheres_asset_load_memory(const void* data, size_t size, const char* name,
                                                                   skinspheres_asset** out_asset);
/* How an asset is set up at load (the *_with loaders). Zero it, set struct_size =
   sizeof(skinspheres_asset_options), then the fields you need; the plain loaders use the defaults
   (all zero). struct_size lets later versions add fields: a size smaller than this version's first
   struct, or larger than this library's, is refused (SKINSPHERES_INVALID_ARGUMENT). */
typedef struct skinspheres_asset_options {
  size_t struct_size;
  /* The narrow phase's margin (set units, >= 0, finite): triangle pairs apart but nearer than this
     are reported as SKINSPHERES_TRIANGLES_WITHIN_MARGIN with their distance and closest points.
     0: intersections only. Pairs within the margin (or the set's rest gap) at rest are never
     reported (rule 3, below), so it is fixed when the asset is loaded. */
  float narrow_margin;
  /* Part pairs intersecting deeper than this share of the character's rest height are
     SKINSPHERES_PARTS_PENETRATING, the others touching; in [0, 1). 0 gives the default, 0.005
     (9 mm on a 1.8 m character); to call every intersection penetrating, give a share below any
     depth, such as 1e-9. */
  float touch_tolerance_share;
} skinspheres_asset_options;

/* skinspheres_asset_load_file / _load_memory with options (NULL: the defaults). */
SKINSPHERES_C_API skinspheres_status skinspheres_asset_load_file_with(const char* path,
                                                                      const skinspheres_asset_options* options,
                                                                      skinspheres_asset** out_asset);
SKINSPHERES_C_API skinspheres_status skinspheres_asset_load_memory_with(const void* data, size_t size, const char* name,
                                                                        const skinspheres_asset_options* options,
                                                                        skinspheres_asset** out_asset);
/* The narrow-phase margin the asset was loaded with (0 for NULL and for a set without its mesh). */
SKINSPHERES_C_API float skinspheres_asset_narrow_margin(const skinspheres_asset* asset);
/* The depth (set units) above which a part pair penetrates: the touch tolerance's share of the rest
   pose's height (0 for NULL and for a set without its mesh). */
SKINSPHERES_C_API float skinspheres_asset_touch_tolerance(const skinspheres_asset* asset);
/* An asset is reference-counted: loading gives the caller one reference, each instance holds one,
   skinspheres_asset_retain adds one. Release drops one: the set is freed with the last (every
   instance made from it destroyed, every retain released). NULL is ignored. Both may be called
   from any thread. */
SKINSPHERES_C_API void skinspheres_asset_release(skinspheres_asset* asset);
/* Adds a reference to the asset (dropped by skinspheres_asset_release), e.g. to keep the asset of
   skinspheres_instance_asset after the instance is destroyed. Returns asset (NULL for NULL). */
SKINSPHERES_C_API skinspheres_asset* skinspheres_asset_retain(skinspheres_asset* asset);

/* Lookups into the asset. The pointers they return (names, rest matrices) stay valid while the
   asset lives (until its last reference is released: see skinspheres_asset_release); NULL for a
   null asset or an index out of range, skinspheres_last_error() then saying which. Counts are 0
   for NULL. */
SKINSPHERES_C_API size_t skinspheres_asset_sphere_count(const skinspheres_asset* asset);
/* The set's joints (see docs: the skin's joints plus their non-joint ancestors, parents first). */
SKINSPHERES_C_API size_t skinspheres_asset_joint_count(const skinspheres_asset* asset);
/* The joint's name, UTF-8, NUL-terminated. */
SKINSPHERES_C_API const char* skinspheres_asset_joint_name(const skinspheres_asset* asset, size_t joint);
/* The joint's world transform in the rest pose the set was fitted in (16 floats, column-major),
   e.g. to check an engine's own rest pose against it. */
SKINSPHERES_C_API const float* skinspheres_asset_joint_rest_world(const skinspheres_asset* asset, size_t joint);
/* 1 when the runtime reads this joint's matrix every frame (it must be in the engine's list); 0
   otherwise, and for NULL or an index out of range. */
SKINSPHERES_C_API int skinspheres_asset_joint_is_read(const skinspheres_asset* asset, size_t joint);
SKINSPHERES_C_API size_t skinspheres_asset_part_count(const skinspheres_asset* asset);
/* The body part's name ("torso", "arm_l", ...), UTF-8, NUL-terminated. */
SKINSPHERES_C_API const char* skinspheres_asset_part_name(const skinspheres_asset* asset, size_t part);
/* Which body part sphere `sphere` (< skinspheres_asset_sphere_count) belongs to: *out_part (an
   index below skinspheres_asset_part_count; the part_i / part_j of its sphere pairs).
   SKINSPHERES_INVALID_ARGUMENT for a null asset or out_part or a sphere out of range (*out_part
   then unchanged). */
SKINSPHERES_C_API skinspheres_status skinspheres_asset_sphere_part(const skinspheres_asset* asset, size_t sphere,
                                                                   size_t* out_part);
/* The joints that move sphere `sphere` and their blend weights (the set's influence lists: weights
   > 0 that sum to 1, in the set's order): out_joints[k] (a set joint, skinspheres_asset_joint_name)
   and out_weights[k] for k < min(capacity, *out_count). Either array may be NULL (not filled);
   *out_count = the sphere's number of joints, SKINSPHERES_BUFFER_TOO_SMALL when capacity is below it
   (the first capacity copied). SKINSPHERES_INVALID_ARGUMENT (*out_count 0) for a null asset or
   out_count, or a sphere out of range. */
SKINSPHERES_C_API skinspheres_status skinspheres_asset_sphere_joints(const skinspheres_asset* asset, size_t sphere,
                                                                     uint32_t* out_joints, float* out_weights,
                                                                     size_t capacity, size_t* out_count);
/* The sphere's main joint: of its joints (skinspheres_asset_sphere_joints), the one of largest
   weight, the lowest joint index among equal weights. Errors as skinspheres_asset_sphere_part
   (and SKINSPHERES_INVALID_DATA for a sphere without joints, which a loaded set never has). */
SKINSPHERES_C_API skinspheres_status skinspheres_asset_sphere_joint(const skinspheres_asset* asset, size_t sphere,
                                                                    size_t* out_joint);
/* Vertices the set was fitted on (exact mode reads that many positions). */
SKINSPHERES_C_API size_t skinspheres_asset_vertex_count(const skinspheres_asset* asset);
/* 1 for a set loaded from a fast-only binary file: exact mode is refused. */
SKINSPHERES_C_API int skinspheres_asset_is_fast_only(const skinspheres_asset* asset);

/* Whether the set was fitted on this character: vertex_count equal and every joint the spheres
   move with named in joint_names (any order; extra joints allowed). SKINSPHERES_MISMATCHED_ASSET
   otherwise, skinspheres_last_error() naming the set's file and the missing joints. */
SKINSPHERES_C_API skinspheres_status skinspheres_asset_check(const skinspheres_asset* asset,
                                                             const char* const* joint_names, size_t joint_count,
                                                             size_t vertex_count);

/* ---- Instances ---- */

/* An instance of the asset (it holds a reference until destroyed). joint_names: the engine's
   joints, in the order its matrices will come (MISMATCHED_ASSET when a joint the spheres move with
   is missing); NULL: matrices in the set's own order (skinspheres_asset_joint_name). The names are
   copied: the caller's strings may be freed on return. */
SKINSPHERES_C_API skinspheres_status skinspheres_instance_create(const skinspheres_asset* asset,
                                                                 const char* const* joint_names, size_t joint_count,
                                                                 skinspheres_instance** out_instance);
/* Frees the instance and drops its reference to the asset. NULL is ignored. */
SKINSPHERES_C_API void skinspheres_instance_destroy(skinspheres_instance* instance);
/* The asset the instance was made from: a borrowed pointer, valid while the instance lives (NULL
   for NULL). skinspheres_asset_retain it to keep it longer. */
SKINSPHERES_C_API skinspheres_asset* skinspheres_instance_asset(const skinspheres_instance* instance);
/* Joint matrices an update reads: joint_count given at creation (or the set's). */
SKINSPHERES_C_API size_t skinspheres_instance_joint_count(const skinspheres_instance* instance);
/* How the engine's joint list given at creation maps onto the set's (0 and nothing for an instance
   made without names):
   - extra joints: the engine's joints the set does not list (never read), in the engine's order;
   - unmapped joints: the set's joints the engine's list lacks, none of them read per frame (e.g.
     Xbot's `Armature`), in the set's order.
   The names (UTF-8) stay valid while the instance lives; NULL for a null instance or an index out
   of range, skinspheres_last_error() then saying which. */
SKINSPHERES_C_API size_t skinspheres_instance_extra_joint_count(const skinspheres_instance* instance);
SKINSPHERES_C_API const char* skinspheres_instance_extra_joint_name(const skinspheres_instance* instance, size_t k);
SKINSPHERES_C_API size_t skinspheres_instance_unmapped_joint_count(const skinspheres_instance* instance);
SKINSPHERES_C_API const char* skinspheres_instance_unmapped_joint_name(const skinspheres_instance* instance, size_t k);

/* Fast refit: joint_world holds 16 floats per joint, joint_count >= skinspheres_instance_joint_count. */
SKINSPHERES_C_API skinspheres_status skinspheres_instance_update_fast(skinspheres_instance* instance,
                                                                      const float* joint_world, size_t joint_count);
/* Exact refit: positions holds 3 floats per vertex, vertex_count >= skinspheres_asset_vertex_count;
   joint_world as above, or NULL with joint_count 0 (sphere centres then from the vertices alone;
   NULL with a count is refused). */
SKINSPHERES_C_API skinspheres_status skinspheres_instance_update_exact(skinspheres_instance* instance,
                                                                       const float* positions, size_t vertex_count,
                                                                       const float* joint_world, size_t joint_count);

/* Where the joint matrices are in memory, in bytes and signed (numpy's strides): element (row r,
   column c) of joint j is the float at (const char*)joint_world + j * joint_stride + r * row_stride
   + c * column_stride, for j below the joint count and r, c < 4 (all 16 are read). The packed
   column-major layout of the plain calls is {64, 4, 16}; row-major (C order, numpy's
   array[j][r][c]) is {64, 16, 4}. Any strides are taken as given (zero and negative too: a
   negative stride reads backwards from joint_world, which points at joint 0's element (0, 0));
   every element they address must be readable. Floats may be unaligned. */
typedef struct skinspheres_matrix_layout {
  ptrdiff_t joint_stride;
  ptrdiff_t row_stride;
  ptrdiff_t column_stride;
} skinspheres_matrix_layout;

/* The update calls with strided inputs: joint matrices laid out as *joint_layout (NULL: the packed
   column-major layout, the plain call exactly), positions as 3 contiguous floats (x, y, z) per vertex
   at a byte stride of position_stride (12: packed; any value, negative and zero too, as above). They
   copy the values into the instance's own buffers (only the matrices and vertices an update reads;
   no copy for the packed layouts) and then run as the plain calls: the same spheres, sphere pairs,
   contacts and statuses, bit for bit. Allocation: as the header's note says. Refused
   (SKINSPHERES_INVALID_ARGUMENT, nothing read) for a null instance, joint_world NULL in fast mode,
   positions NULL in exact mode, and joint_world NULL with joint_count > 0. */
SKINSPHERES_C_API skinspheres_status
skinspheres_instance_update_fast_strided(skinspheres_instance* instance, const float* joint_world, size_t joint_count,
                                         const skinspheres_matrix_layout* joint_layout);
SKINSPHERES_C_API skinspheres_status skinspheres_instance_update_exact_strided(
    skinspheres_instance* instance, const float* positions, size_t vertex_count, ptrdiff_t position_stride,
    const float* joint_world, size_t joint_count, const skinspheres_matrix_layout* joint_layout);

/* The broad phase on the current spheres; *out_count = the number of sphere pairs that overlap (0
   and an error when the last update failed). */
SKINSPHERES_C_API skinspheres_status skinspheres_instance_find_sphere_pairs(skinspheres_instance* instance,
                                                                            size_t* out_count);
/* Copies the last sphere pairs found (sorted by sphere_i, sphere_j) into out[0, capacity);
   *out_count = the total count (when not NULL). SKINSPHERES_BUFFER_TOO_SMALL when capacity < the
   count: the first capacity are copied and *out_count is still the total; call again with a buffer
   of *out_count, no need to find them again. */
SKINSPHERES_C_API skinspheres_status skinspheres_instance_get_sphere_pairs(const skinspheres_instance* instance,
                                                                           skinspheres_sphere_pair* out,
                                                                           size_t capacity, size_t* out_count);
/* The last sphere pairs found, in place; *out_count set. Valid until the instance's next update
   (single or crowd), find (of sphere pairs or contacts) or destroy; NULL (count 0) for NULL. */
SKINSPHERES_C_API const skinspheres_sphere_pair* skinspheres_instance_sphere_pairs(const skinspheres_instance* instance,
                                                                                   size_t* out_count);
/* The current spheres, 4 floats each (x, y, z, radius), NULL when the last update failed. Valid
   until the instance's next update (single or crowd) or destroy. */
SKINSPHERES_C_API const float* skinspheres_instance_spheres(const skinspheres_instance* instance, size_t* out_count);
/* The outcome of the instance's last update or search; *message (when not NULL) gets a static
   string saying why (valid for the program's life). */
SKINSPHERES_C_API skinspheres_status skinspheres_instance_status(const skinspheres_instance* instance,
                                                                 const char** message);
/* Sizes the buffers so that frames with up to `count` sphere pairs, and as many part and
   triangle pairs, never allocate, and the single query's cache (else sized by the first
   skinspheres_instance_find_sphere_pairs; never, for an instance the crowd calls only ever query in
   a batch); for an asset with a mesh, also the narrow phase's scratch (else sized by the first
   skinspheres_instance_find_contacts). */
SKINSPHERES_C_API skinspheres_status skinspheres_instance_reserve_contacts(skinspheres_instance* instance,
                                                                           size_t count);
/* Sizes only the sphere-pair buffer (skinspheres_instance_find_sphere_pairs's) for up to `count` pairs,
   and the single query's cache: for an instance that runs only the broad phase, which then holds no
   triangle-pair room and no narrow-phase scratch (a later skinspheres_instance_find_contacts sizes
   those itself). */
SKINSPHERES_C_API skinspheres_status skinspheres_instance_reserve_sphere_pairs(skinspheres_instance* instance,
                                                                               size_t count);

/* ---- Triangle contacts (the narrow phase) ----
   Behind the sphere pairs, the triangles that really touch: pairs of source triangles (the set's
   triangle numbering, the source file's order) that intersect, or lie within the asset's margin,
   grouped by body-part pair. Needs a set with its mesh (a set fitted by this version, as JSON or a
   full binary file); a fast-only binary set or an older set without a mesh is refused
   (SKINSPHERES_VERSION_MISMATCH). Same pattern as the sphere pairs: find gives the counts, the
   get calls copy into the caller's buffers.

   The contact rules (SKINSPHERES_RULES_TRIANGLES; runtime/include/skinspheres/runtime/narrow_phase/
   contact_rules.h states them for C++). Two triangles that intersect (or come within the margin) are
   a contact unless
     1. they share a vertex (by rest position);
     2. their joints are at most skinspheres_asset_contact_hops bones apart in the skin's joint tree
        (a triangle's joint: the joint its three vertices weigh most in sum; nodes that are not
        joints are skipped);
     3. they intersect, or lie closer than skinspheres_asset_rest_gap (or the margin), in the rest pose.
   A triangle with no area in the frame (two corners equal, or all three on a line) is never a
   contact: its edges belong to the triangles beside it, which are tested.
   The same pairs whatever the fit: the spheres only filter (a sphere pair is never reported only when
   rule 2 excludes every triangle pair it could hold). A set written before these rules
   (SKINSPHERES_RULES_SPHERE_PAIRS: JSON before version 4, binary before layout 6) keeps the rules it
   was fitted with, stated on sphere pairs, overlapping at rest among them: what it reports depends on
   its fit; fit the character again for the rules on triangles. */

typedef enum skinspheres_contact_rules {
  SKINSPHERES_RULES_SPHERE_PAIRS = 0, /* a set written before the rules on triangles */
  SKINSPHERES_RULES_TRIANGLES = 1     /* the rules above */
} skinspheres_contact_rules;

/* The asset's rules (skinspheres_contact_rules; SKINSPHERES_RULES_SPHERE_PAIRS for NULL), rule 2's
   hops (0, 1 or 2; 0 with rules on sphere pairs or NULL) and rule 3's rest gap in set units (0 likewise). */
SKINSPHERES_C_API int skinspheres_asset_contact_rules(const skinspheres_asset* asset);
SKINSPHERES_C_API uint32_t skinspheres_asset_contact_hops(const skinspheres_asset* asset);
SKINSPHERES_C_API float skinspheres_asset_rest_gap(const skinspheres_asset* asset);

typedef enum skinspheres_triangle_contact_kind {
  SKINSPHERES_TRIANGLES_INTERSECTING = 0, /* the two closed triangles share a point */
  SKINSPHERES_TRIANGLES_WITHIN_MARGIN = 1 /* apart, but closer than the asset's margin */
} skinspheres_triangle_contact_kind;

/* A part pair's contact: penetrating when its triangles intersect deeper than the asset's touch
   tolerance (skinspheres_asset_touch_tolerance), else touching (surfaces within the margin, or
   intersecting by less than the tolerance). */
typedef enum skinspheres_part_contact_kind {
  SKINSPHERES_PARTS_TOUCHING = 0,
  SKINSPHERES_PARTS_PENETRATING = 1
} skinspheres_part_contact_kind;

/* One body-part pair in contact this frame (part_a <= part_b; skinspheres_asset_part_name).
   Its triangle pairs are entries [first_triangle_pair, first_triangle_pair +
   triangle_pair_count) of the frame's triangle contacts (skinspheres_instance_get_triangle_contacts
   with SKINSPHERES_ALL_PART_PAIRS), or all of them with its own index. 56 bytes. */
typedef struct skinspheres_part_contact {
  uint16_t part_a;
  uint16_t part_b;
  uint32_t first_triangle_pair;
  uint32_t triangle_pair_count;
  uint32_t intersecting_count; /* how many of those are SKINSPHERES_TRIANGLES_INTERSECTING */
  uint32_t sphere_pair_count;  /* sphere pairs that own those triangle pairs where they touch (i <= j) */
  float depth;                 /* penetration depth estimate (set units); 0 without intersections */
  float min_distance;          /* 0 with intersections, else the smallest within-margin distance */
  float normal[3];             /* contact normal, from part_b towards part_a (0 without intersections) */
  float center[3];             /* contact centre, or the closest pair's point */
  uint32_t kind;               /* skinspheres_part_contact_kind */
} skinspheres_part_contact;

/* One pair of touching triangles: triangle_a of the part pair's part_a, triangle_b of its part_b
   (same part: triangle_a < triangle_b). 52 bytes. */
typedef struct skinspheres_triangle_contact {
  uint32_t triangle_a;
  uint32_t triangle_b;
  uint32_t kind;  /* skinspheres_triangle_contact_kind */
  float distance; /* 0 when intersecting, else the closest distance (< margin) */
  float point[3]; /* a representative point: the midpoint of on_a and on_b */
  float on_a[3];  /* intersecting: the ends of the intersection segment; within margin: the */
  float on_b[3];  /* closest points on triangle_a and triangle_b */
} skinspheres_triangle_contact;

/* The part_contact argument of skinspheres_instance_get_triangle_contacts for every part pair's:
   an enum constant (binding generators see it; 0.2 had a #define), of value -1, which the size_t
   parameter receives as SIZE_MAX ((size_t)-1, as in 0.2). A binding passes -1 converted to size_t
   (ctypes: c_size_t(-1).value). */
typedef enum skinspheres_part_pair_selector { SKINSPHERES_ALL_PART_PAIRS = -1 } skinspheres_part_pair_selector;

/* 1 when the asset can give triangle contacts (it holds its mesh). */
SKINSPHERES_C_API int skinspheres_asset_has_triangle_contacts(const skinspheres_asset* asset);

/* Runs the narrow phase behind the last update's sphere pairs (skinspheres_instance_find_sphere_pairs runs first if it
   has not since that update). positions: the skinned positions the spheres were refitted from
   (3 floats per vertex, vertex_count >= skinspheres_asset_vertex_count), or NULL with vertex_count 0:
   the instance then skins only the vertices it tests, from the last update's joint matrices (the
   usual choice after update_fast). *out_part_pairs and *out_triangle_pairs (either may be NULL) get
   the counts. Allocation: as the header's note says. */
SKINSPHERES_C_API skinspheres_status skinspheres_instance_find_contacts(skinspheres_instance* instance,
                                                                        const float* positions, size_t vertex_count,
                                                                        size_t* out_part_pairs,
                                                                        size_t* out_triangle_pairs);
/* The same with positions at a byte stride (skinspheres_instance_update_exact_strided; NULL with
   vertex_count 0: no positions, as above): the same contacts, bit for bit. */
SKINSPHERES_C_API skinspheres_status skinspheres_instance_find_contacts_strided(
    skinspheres_instance* instance, const float* positions, size_t vertex_count, ptrdiff_t position_stride,
    size_t* out_part_pairs, size_t* out_triangle_pairs);
/* Copies the last find's part pairs (sorted by part_a, part_b) into out[0, capacity); *out_count =
   the total count. SKINSPHERES_BUFFER_TOO_SMALL when capacity < the count (the first capacity are
   copied, *out_count still the total). */
SKINSPHERES_C_API skinspheres_status skinspheres_instance_get_part_contacts(const skinspheres_instance* instance,
                                                                            skinspheres_part_contact* out,
                                                                            size_t capacity, size_t* out_count);
/* Copies the triangle pairs of part pair `part_contact` (an index below the part-pair count), or of
   every part pair (SKINSPHERES_ALL_PART_PAIRS: grouped by part pair in the part pairs' order, each
   group sorted by triangle_a, triangle_b), into out[0, capacity); *out_count = the total count of
   that selection. SKINSPHERES_BUFFER_TOO_SMALL as above; SKINSPHERES_INVALID_ARGUMENT (*out_count 0)
   for an index out of range. */
SKINSPHERES_C_API skinspheres_status skinspheres_instance_get_triangle_contacts(const skinspheres_instance* instance,
                                                                                size_t part_contact,
                                                                                skinspheres_triangle_contact* out,
                                                                                size_t capacity, size_t* out_count);

/* ---- Crowds, on the engine's job system ---- */

/* A range of work: call body(body_context, begin, end). */
typedef void (*skinspheres_range_fn)(void* body_context, size_t begin, size_t end);
/* The engine's parallel loop: call body on disjoint ranges covering [0, count) exactly once, on any
   threads, in any order, and return when all have returned; grain is a hint (>= 1). */
typedef void (*skinspheres_parallel_for_fn)(void* user, size_t count, size_t grain, skinspheres_range_fn body,
                                            void* body_context);

typedef struct skinspheres_frame_input {
  const float* joint_world; /* 16 floats per joint */
  size_t joint_count;
  const float* positions; /* exact mode: 3 floats per vertex; fast mode: ignored */
  size_t vertex_count;
} skinspheres_frame_input;

/* Update, then find the sphere pairs of, instances[i] with inputs[i], for i < count, through parallel_for (NULL: the
   library's default: TBB, or serial in a build without TBB). Results are identical to calling each
   instance alone. Each index of the loop is a block of 16 consecutive instances when the CPU has
   AVX-512F and the mode is fast (they are refitted and queried together; the last block may be
   shorter), one instance otherwise: parallel_for's count is the number of blocks. It keeps no
   joint matrices for a later skinspheres_instance_find_contacts without positions (refused until
   the instance's next update that keeps them: the single-instance updates and
   skinspheres_crowd_update_and_find_contacts). SKINSPHERES_INVALID_DATA when at least one
   instance failed (ask it for its own status); SKINSPHERES_INVALID_ARGUMENT (nothing runs) for a
   null array or instance. */
SKINSPHERES_C_API skinspheres_status skinspheres_crowd_update_and_find_sphere_pairs(
    skinspheres_instance* const* instances, const skinspheres_frame_input* inputs, size_t count,
    skinspheres_refit_mode mode, skinspheres_parallel_for_fn parallel_for, void* user);
/* The same, then skinspheres_instance_find_contacts for every instance, on the thread that updated
   it: from the input's positions in exact mode, skinning only what it tests from the joint matrices
   in fast mode; each index of parallel_for is one instance. SKINSPHERES_INVALID_DATA also when an
   instance's asset has no mesh (its status says so). */
SKINSPHERES_C_API skinspheres_status skinspheres_crowd_update_and_find_contacts(
    skinspheres_instance* const* instances, const skinspheres_frame_input* inputs, size_t count,
    skinspheres_refit_mode mode, skinspheres_parallel_for_fn parallel_for, void* user);

/* A crowd frame input with strides (a struct of its own: skinspheres_frame_input keeps its layout).
   joint_layout: NULL for packed column-major, else as skinspheres_matrix_layout says (read during
   the call only); position_stride: bytes from one vertex to the next (12: packed). A null pointer
   with a count is taken as no input, as in skinspheres_frame_input (the instance then fails and
   says why). */
typedef struct skinspheres_frame_input_strided {
  const float* joint_world;
  size_t joint_count;
  const skinspheres_matrix_layout* joint_layout;
  const float* positions; /* exact mode; fast mode: ignored (not read) */
  size_t vertex_count;
  ptrdiff_t position_stride;
} skinspheres_frame_input_strided;

/* The two crowd calls with strided inputs: the same results, bit for bit, as with the same values
   packed. Each instance's gather buffers are sized on the calling thread before the loop (the first
   time it is given a layout other than the packed one); the copies are made on the thread that runs
   the instance. */
SKINSPHERES_C_API skinspheres_status skinspheres_crowd_update_and_find_sphere_pairs_strided(
    skinspheres_instance* const* instances, const skinspheres_frame_input_strided* inputs, size_t count,
    skinspheres_refit_mode mode, skinspheres_parallel_for_fn parallel_for, void* user);
SKINSPHERES_C_API skinspheres_status skinspheres_crowd_update_and_find_contacts_strided(
    skinspheres_instance* const* instances, const skinspheres_frame_input_strided* inputs, size_t count,
    skinspheres_refit_mode mode, skinspheres_parallel_for_fn parallel_for, void* user);

/* ---- Pose fixing ---- */

/* A pose corrected so that no part pair penetrates deeper than a limit, turning as few joints as
   little as it can (the per-frame step of `skinspheres fix`; docs/TOOL.md#fixing-clips). One pose
   alone: an engine calling it every frame should ease the corrections it applies. Each call plays
   the pose a few times (refit, broad and narrow phase): some hundreds of microseconds to a few
   milliseconds per call (docs/PERFORMANCE.md, BM_FixPose). One fixer per thread. */
typedef struct skinspheres_pose_fixer skinspheres_pose_fixer;

/* What one call did: holds (no part pair deeper than the limit after), least-squares steps taken,
   deepest penetration before and after (the set's units). 16 bytes. */
typedef struct skinspheres_pose_fix_result {
  int32_t holds;
  int32_t steps;
  float deepest_before;
  float deepest_after;
} skinspheres_pose_fix_result;

/* A fixer over the asset (it holds a reference until destroyed). INVALID_ARGUMENT for a null
   argument or a set without mesh. */
SKINSPHERES_C_API skinspheres_status skinspheres_pose_fixer_create(const skinspheres_asset* asset,
                                                                   skinspheres_pose_fixer** out_fixer);
/* Frees the fixer and drops its reference to the asset. NULL is ignored. */
SKINSPHERES_C_API void skinspheres_pose_fixer_destroy(skinspheres_pose_fixer* fixer);
/* locals: joint_count joints in the set's order (skinspheres_asset_joint_name), 10 floats each:
   translation x y z, rotation quaternion x y z w, scale x y z; roots in model space. The rotations
   are corrected in place (translations and scales are not changed). max_depth: the set's units,
   <= 0 for the asset's touch tolerance. out_result may be NULL. INVALID_ARGUMENT for a null
   fixer or locals, or a joint count other than the asset's. */
SKINSPHERES_C_API skinspheres_status skinspheres_pose_fixer_fix(skinspheres_pose_fixer* fixer, float* locals,
                                                                size_t joint_count, float max_depth,
                                                                skinspheres_pose_fix_result* out_result);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* SKINSPHERES_SKINSPHERES_H_ */
