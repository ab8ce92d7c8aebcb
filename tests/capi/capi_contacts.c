/* A plain C99 program that drives the built-in character through the C API as an engine would:
   load the sphere set (binary from a file, JSON from memory), create instances that take joint
   matrices in the engine's own joint order, update fast and exact every frame of a clip, query
   contacts (count first, then fill), find the triangle contacts behind them (by part pair and
   all at once, count first, then fill), and run a crowd on its own parallel loop. Every frame's
   sphere, part-pair and triangle contacts must equal, byte for byte, what the C++ API found
   (capi_reference writes them).
   Usage: capi_contacts DIR [MARGIN] (DIR holding set.ssb, set.json, set_fast.ssb, frames.bin;
   MARGIN: the narrow-phase margin capi_reference used, passed in skinspheres_asset_options). */
#ifdef __cplusplus
#error "this test must be compiled as C"
#endif
#if !defined(__STDC_VERSION__) || __STDC_VERSION__ != 199901L
#error "this test must be compiled as C99"
#endif

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "skinspheres/skinspheres.h"

static int failures = 0;
static float touch_tolerance = 0.0f;     /* the assets' (set units) */
static unsigned long part_kinds[2] = {0}; /* part pairs seen touching, penetrating */

static void check(int ok, const char* what, size_t frame) {
  if (!ok) {
    fprintf(stderr, "FAILED: %s (frame %lu): %s\n", what, (unsigned long)frame, skinspheres_last_error());
    ++failures;
  }
}

/* dir/name in a static buffer (valid until the next call). */
static const char* join(const char* dir, const char* name) {
  static char path[4096];
  snprintf(path, sizeof path, "%s/%s", dir, name);
  return path;
}

static void* read_all(const char* path, size_t* size) {
  FILE* f = fopen(path, "rb");
  void* data;
  long n;
  if (!f) return NULL;
  fseek(f, 0, SEEK_END);
  n = ftell(f);
  fseek(f, 0, SEEK_SET);
  data = malloc((size_t)n + 1);
  *size = fread(data, 1, (size_t)n, f);
  fclose(f);
  return data;
}

static uint32_t read_u32(const unsigned char** p) {
  uint32_t v;
  memcpy(&v, *p, 4);
  *p += 4;
  return v;
}

/* What capi_reference wrote for one frame. */
typedef struct frame {
  const float* joint_world;
  const float* positions;
  uint32_t contact_count[2]; /* fast, exact */
  const skinspheres_sphere_pair* contacts[2];
  uint32_t part_count[2];    /* the narrow phase: part pairs and triangle pairs, fast and exact */
  const skinspheres_part_contact* parts[2];
  uint32_t triangle_count[2];
  const skinspheres_triangle_contact* triangles[2];
} frame;

static int same_contacts(const skinspheres_sphere_pair* a, size_t na, const skinspheres_sphere_pair* b, size_t nb) {
  return na == nb && (na == 0 || memcmp(a, b, na * sizeof(skinspheres_sphere_pair)) == 0);
}
static int same_triangles(const skinspheres_triangle_contact* a, size_t na, const skinspheres_triangle_contact* b,
                          size_t nb) {
  return na == nb && (na == 0 || memcmp(a, b, na * sizeof(skinspheres_triangle_contact)) == 0);
}

/* The frame's triangle contacts through the C API, against what the C++ API found (mode m): the
   counts, the part pairs, every triangle pair at once and part pair by part pair, a buffer too
   small, an index out of range. Returns the number of triangle pairs. */
static size_t check_triangle_contacts(skinspheres_instance* inst, const frame* fr, int m, size_t f, size_t vertex_count,
                                      skinspheres_part_contact* parts, size_t part_capacity,
                                      skinspheres_triangle_contact* triangles, size_t triangle_capacity) {
  size_t part_count = 0, triangle_count = 0, written = 0, k;
  skinspheres_triangle_contact one[1];
  check(skinspheres_instance_find_contacts(inst, m == 0 ? NULL : fr->positions, m == 0 ? 0 : vertex_count,
                                           &part_count, &triangle_count) == SKINSPHERES_OK,
        m == 0 ? "find_contacts (skinning from the joints)" : "find_contacts (skinned positions)", f);
  check(part_count == fr->part_count[m] && triangle_count == fr->triangle_count[m],
        "part and triangle pair counts equal the C++ API's", f);
  check(skinspheres_instance_get_part_contacts(inst, parts, part_capacity, &written) == SKINSPHERES_OK &&
            written == part_count,
        "get_part_contacts", f);
  check(written == 0 || memcmp(parts, fr->parts[m], written * sizeof(skinspheres_part_contact)) == 0,
        "part contacts equal the C++ API's", f);
  for (k = 0; k < written && k < part_capacity; ++k) {
    const int deeper = parts[k].intersecting_count > 0 && parts[k].depth > touch_tolerance;
    check(parts[k].kind == (deeper ? SKINSPHERES_PARTS_PENETRATING : SKINSPHERES_PARTS_TOUCHING),
          "a part pair penetrates exactly when it intersects deeper than the touch tolerance", f);
    ++part_kinds[deeper];
  }
  check(skinspheres_instance_get_triangle_contacts(inst, SKINSPHERES_ALL_PART_PAIRS, triangles, triangle_capacity,
                                                   &written) == SKINSPHERES_OK,
        "get_triangle_contacts", f);
  check(same_triangles(triangles, written, fr->triangles[m], fr->triangle_count[m]),
        m == 0 ? "fast triangle contacts equal the C++ API's" : "exact triangle contacts equal the C++ API's", f);
  for (k = 0; k < part_count && k < part_capacity; ++k) {
    const skinspheres_part_contact* pc = &fr->parts[m][k];
    check(skinspheres_instance_get_triangle_contacts(inst, k, triangles, triangle_capacity, &written) == SKINSPHERES_OK,
          "get_triangle_contacts of a part pair", f);
    check(pc->first_triangle_pair + pc->triangle_pair_count <= fr->triangle_count[m] &&
              same_triangles(triangles, written, fr->triangles[m] + pc->first_triangle_pair, pc->triangle_pair_count),
          "a part pair's triangle contacts equal the C++ API's", f);
  }
  check(skinspheres_instance_get_triangle_contacts(inst, part_count, triangles, triangle_capacity, &written) ==
            SKINSPHERES_INVALID_ARGUMENT && written == 0,
        "a part-pair index out of range is refused", f);
  if (triangle_count > 1) {
    check(skinspheres_instance_get_triangle_contacts(inst, SKINSPHERES_ALL_PART_PAIRS, one, 1, &written) ==
                  SKINSPHERES_BUFFER_TOO_SMALL && written == triangle_count &&
              memcmp(&one[0], &fr->triangles[m][0], sizeof one[0]) == 0,
          "a small triangle buffer is refused, its first entry copied, the total count given", f);
  }
  return triangle_count;
}

/* The layouts the strided calls are tested with: the frame's matrices and positions rewritten. */
typedef struct strided_frame {
  float* row_major;          /* joints x 16, C order: {64, 16, 4} */
  unsigned char* interleaved; /* 69-byte records: a tag byte, the matrix row-major, 4 bytes: {69, 16, 4}, base + 1 */
  float* reversed;           /* joints in reverse order, each column-major with its rows reversed: {-64, -4, 16} */
  float* vertices;           /* 8 floats per vertex (position, normal, uv): stride 32 */
  float* vertices_reversed;  /* packed, last vertex first: stride -12 from the last record */
} strided_frame;

static const skinspheres_matrix_layout row_major_layout = {64, 16, 4};
static const skinspheres_matrix_layout interleaved_layout = {69, 16, 4};
static const skinspheres_matrix_layout reversed_layout = {-64, -4, 16};

static void make_strided(strided_frame* sf, const float* joint_world, size_t joints, const float* positions,
                         size_t vertices) {
  size_t j, r, c, v;
  for (j = 0; j < joints; ++j) {
    const float* m = joint_world + 16 * j; /* column-major: element (r, c) at m[4c + r] */
    sf->interleaved[69 * j] = 0xAB;
    for (r = 0; r < 4; ++r) {
      for (c = 0; c < 4; ++c) {
        sf->row_major[16 * j + 4 * r + c] = m[4 * c + r];
        memcpy(sf->interleaved + 69 * j + 1 + 16 * r + 4 * c, &m[4 * c + r], sizeof(float));
        sf->reversed[16 * (joints - 1 - j) + 4 * c + (3 - r)] = m[4 * c + r];
      }
    }
  }
  for (v = 0; v < vertices; ++v) {
    memcpy(sf->vertices + 8 * v, positions + 3 * v, 3 * sizeof(float));
    sf->vertices[8 * v + 3] = sf->vertices[8 * v + 6] = -1.0f; /* normal and uv: not read */
    memcpy(sf->vertices_reversed + 3 * (vertices - 1 - v), positions + 3 * v, 3 * sizeof(float));
  }
}

/* Spheres and sphere pairs of inst, equal byte for byte to a copy taken after the packed call. */
static int same_state(skinspheres_instance* inst, const float* spheres, size_t sphere_count,
                      const skinspheres_sphere_pair* pairs, size_t pair_count) {
  size_t n = 0, np = 0;
  const float* now = skinspheres_instance_spheres(inst, &n);
  const skinspheres_sphere_pair* now_pairs;
  if (skinspheres_instance_find_sphere_pairs(inst, &np) != SKINSPHERES_OK) return 0;
  now_pairs = skinspheres_instance_sphere_pairs(inst, &np);
  return now && n == sphere_count && memcmp(now, spheres, 4 * n * sizeof(float)) == 0 &&
         same_contacts(now_pairs, np, pairs, pair_count);
}

/* Every strided layout on instance s gives, frame by frame, the packed call's spheres and sphere
   pairs (bit for bit) and the C++ API's sphere pairs and triangle contacts. */
static void check_strided(skinspheres_instance* s, const frame* fr, size_t f, const strided_frame* sf,
                          size_t joint_count, size_t vertex_count, float* spheres,
                          skinspheres_triangle_contact* triangles, size_t triangle_capacity) {
  const float* last_vertex = sf->vertices_reversed + 3 * (vertex_count - 1);
  const float* last_joint = sf->reversed + 16 * (joint_count - 1) + 3; /* joint 0's element (0, 0) */
  const skinspheres_matrix_layout* layouts[3];
  const float* bases[3];
  size_t n = 0, k, written = 0, parts = 0, tris = 0;
  int m;
  layouts[0] = &row_major_layout;
  layouts[1] = &interleaved_layout;
  layouts[2] = &reversed_layout;
  bases[0] = sf->row_major;
  bases[1] = (const float*)(const void*)(sf->interleaved + 1);
  bases[2] = last_joint;
  for (m = 0; m < 2; ++m) {
    const float* packed;
    check((m == 0 ? skinspheres_instance_update_fast(s, fr->joint_world, joint_count)
                  : skinspheres_instance_update_exact(s, fr->positions, vertex_count, fr->joint_world, joint_count)) ==
              SKINSPHERES_OK,
          "packed update for the strided comparison", f);
    packed = skinspheres_instance_spheres(s, &n);
    memcpy(spheres, packed, 4 * n * sizeof(float));
    for (k = 0; k < 3; ++k) {
      const skinspheres_status st =
          m == 0 ? skinspheres_instance_update_fast_strided(s, bases[k], joint_count, layouts[k])
                 : skinspheres_instance_update_exact_strided(s, k == 2 ? last_vertex : sf->vertices, vertex_count,
                                                             k == 2 ? -12 : 32, bases[k], joint_count, layouts[k]);
      check(st == SKINSPHERES_OK, m == 0 ? "update_fast_strided" : "update_exact_strided", f);
      check(same_state(s, spheres, n, fr->contacts[m], fr->contact_count[m]),
            k == 0   ? "row-major matrices: the packed call's spheres and the C++ API's sphere pairs"
            : k == 1 ? "interleaved, unaligned matrices: the packed call's spheres and the C++ API's sphere pairs"
                     : "negative strides: the packed call's spheres and the C++ API's sphere pairs",
            f);
    }
    /* The narrow phase from strided positions (exact mode's), or without positions (fast mode). */
    check(skinspheres_instance_find_contacts_strided(s, m == 0 ? NULL : last_vertex, m == 0 ? 0 : vertex_count, -12,
                                                     &parts, &tris) == SKINSPHERES_OK &&
              skinspheres_instance_get_triangle_contacts(s, SKINSPHERES_ALL_PART_PAIRS, triangles, triangle_capacity,
                                                         &written) == SKINSPHERES_OK &&
              same_triangles(triangles, written, fr->triangles[m], fr->triangle_count[m]),
          "find_contacts_strided: the C++ API's triangle contacts", f);
  }
  /* The plain layout spelled out is the plain call; a null data pointer with a count is refused. */
  {
    const skinspheres_matrix_layout packed_layout = {64, 4, 16};
    const skinspheres_sphere_pair* pairs;
    check(skinspheres_instance_update_fast_strided(s, fr->joint_world, joint_count, &packed_layout) == SKINSPHERES_OK &&
              skinspheres_instance_find_sphere_pairs(s, &n) == SKINSPHERES_OK,
          "the packed layout spelled out", f);
    pairs = skinspheres_instance_sphere_pairs(s, &n);
    check(same_contacts(pairs, n, fr->contacts[0], fr->contact_count[0]), "the packed layout: the C++ API's pairs", f);
    check(skinspheres_instance_update_exact_strided(s, fr->positions, vertex_count, 12, NULL, joint_count, NULL) ==
                  SKINSPHERES_INVALID_ARGUMENT &&
              strchr(skinspheres_last_error(), '\n') == NULL && strstr(skinspheres_last_error(), "null") != NULL,
          "null joint matrices with a count refused", f);
    check(skinspheres_instance_update_fast_strided(NULL, fr->joint_world, joint_count, NULL) ==
              SKINSPHERES_INVALID_ARGUMENT,
          "null instance refused", f);
  }
}

/* The engine's job system, simplified: ranges of `grain` items, last range first. */
static void reversed_parallel_for(void* user, size_t count, size_t grain, skinspheres_range_fn body, void* ctx) {
  size_t begin;
  int* calls = (int*)user;
  if (grain == 0) grain = 1;
  begin = (count - 1) / grain * grain;
  for (;;) {
    size_t end = begin + grain < count ? begin + grain : count;
    body(ctx, begin, end);
    ++*calls;
    if (begin == 0) break;
    begin -= grain;
  }
}

int main(int argc, char** argv) {
  const char* dir;
  size_t frames_size = 0, json_size = 0, k, f, total[2] = {0, 0}, triangle_total[2] = {0, 0};
  unsigned char* frames_data;
  const unsigned char* p;
  char* json_text;
  uint32_t joint_count, vertex_count, frame_count;
  const char** names;
  frame* frames;
  skinspheres_asset *binary = NULL, *json = NULL, *fast_only = NULL, *missing = NULL;
  skinspheres_instance *a = NULL, *b = NULL, *c = NULL, *in_set_order = NULL, *strided = NULL;
  strided_frame sf;
  float* sphere_copy;
  skinspheres_sphere_pair small[1];
  skinspheres_sphere_pair* buffer;
  size_t capacity = 4096, part_capacity = 256, triangle_capacity = 65536;
  skinspheres_part_contact* part_buffer;
  skinspheres_triangle_contact* triangle_buffer;
  int parallel_calls = 0;
  skinspheres_asset_options options;
  size_t within_margin = 0;

  if (argc != 2 && argc != 3) {
    fprintf(stderr, "usage: capi_contacts DIR [MARGIN]\n");
    return 2;
  }
  dir = argv[1];
  memset(&options, 0, sizeof options);
  options.struct_size = sizeof options;
  options.narrow_margin = argc == 3 ? strtof(argv[2], NULL) : 0.0f;

  /* Versions: the header's and the library's agree. */
  check(skinspheres_version() == SKINSPHERES_VERSION, "skinspheres_version() == SKINSPHERES_VERSION", 0);
  check(strcmp(skinspheres_version_string(), SKINSPHERES_VERSION_STRING) == 0, "version string", 0);
  check(strcmp(skinspheres_status_string(SKINSPHERES_FILE_NOT_FOUND), "file not found") == 0, "status string", 0);

  /* A missing file: its status and a message naming it. */
  check(skinspheres_asset_load_file("no_such_set.ssb", &missing) == SKINSPHERES_FILE_NOT_FOUND && missing == NULL,
        "missing file refused", 0);
  check(strstr(skinspheres_last_error(), "no_such_set.ssb: file not found") != NULL, "missing file named", 0);
  /* The last error is one line: a newline in the name is escaped; an empty path is named as such. */
  check(skinspheres_asset_load_file("no\nsuch.ssb", &missing) == SKINSPHERES_FILE_NOT_FOUND, "missing file refused", 0);
  check(strstr(skinspheres_last_error(), "no\\nsuch.ssb: file not found") != NULL &&
            strchr(skinspheres_last_error(), '\n') == NULL,
        "a newline in the name is escaped", 0);
  check(skinspheres_asset_load_file("", &missing) == SKINSPHERES_INVALID_ARGUMENT, "empty path refused", 0);
  check(strstr(skinspheres_last_error(), "empty path") == skinspheres_last_error(), "empty path named", 0);

  /* The clip as the engine has it. */
  frames_data = (unsigned char*)read_all(join(dir, "frames.bin"), &frames_size);
  if (!frames_data) {
    fprintf(stderr, "cannot read %s/frames.bin\n", dir);
    return 2;
  }
  p = frames_data;
  joint_count = read_u32(&p);
  vertex_count = read_u32(&p);
  frame_count = read_u32(&p);
  names = (const char**)malloc(joint_count * sizeof(char*));
  for (k = 0; k < joint_count; ++k) {
    uint32_t n = read_u32(&p);
    char* name = (char*)malloc(n + 1);
    memcpy(name, p, n);
    name[n] = '\0';
    names[k] = name;
    p += (n + 3) / 4 * 4; /* names are padded to 4 bytes: the floats that follow stay aligned */
  }
  frames = (frame*)malloc(frame_count * sizeof(frame));
  for (f = 0; f < frame_count; ++f) {
    int m;
    frames[f].joint_world = (const float*)p;
    p += 16 * sizeof(float) * joint_count;
    frames[f].positions = (const float*)p;
    p += 3 * sizeof(float) * vertex_count;
    for (m = 0; m < 2; ++m) {
      frames[f].contact_count[m] = read_u32(&p);
      frames[f].contacts[m] = (const skinspheres_sphere_pair*)p;
      p += sizeof(skinspheres_sphere_pair) * frames[f].contact_count[m];
      frames[f].part_count[m] = read_u32(&p);
      frames[f].parts[m] = (const skinspheres_part_contact*)p;
      p += sizeof(skinspheres_part_contact) * frames[f].part_count[m];
      frames[f].triangle_count[m] = read_u32(&p);
      frames[f].triangles[m] = (const skinspheres_triangle_contact*)p;
      p += sizeof(skinspheres_triangle_contact) * frames[f].triangle_count[m];
    }
  }
  if ((size_t)(p - frames_data) != frames_size) {
    fprintf(stderr, "frames.bin: %lu bytes read of %lu\n", (unsigned long)(p - frames_data), (unsigned long)frames_size);
    return 2;
  }

  /* Options that cannot be read, and margins the narrow phase cannot use, are refused. */
  {
    skinspheres_asset_options bad = options;
    bad.struct_size = sizeof(size_t);
    check(skinspheres_asset_load_file_with(join(dir, "set.ssb"), &bad, &missing) == SKINSPHERES_INVALID_ARGUMENT &&
              missing == NULL && strstr(skinspheres_last_error(), "struct_size") != NULL,
          "options too small refused", 0);
    bad.struct_size = sizeof options + 8;
    check(skinspheres_asset_load_file_with(join(dir, "set.ssb"), &bad, &missing) == SKINSPHERES_INVALID_ARGUMENT,
          "options from a newer header refused", 0);
    bad = options;
    bad.narrow_margin = -0.01f;
    check(skinspheres_asset_load_file_with(join(dir, "set.ssb"), &bad, &missing) == SKINSPHERES_INVALID_ARGUMENT &&
              strstr(skinspheres_last_error(), "margin") != NULL,
          "a negative margin refused", 0);
    bad.narrow_margin = (float)strtod("nan", NULL);
    check(skinspheres_asset_load_file_with(join(dir, "set.ssb"), &bad, &missing) == SKINSPHERES_INVALID_ARGUMENT,
          "a NaN margin refused", 0);
    bad = options;
    bad.touch_tolerance_share = -0.01f;
    check(skinspheres_asset_load_file_with(join(dir, "set.ssb"), &bad, &missing) == SKINSPHERES_INVALID_ARGUMENT &&
              strstr(skinspheres_last_error(), "touch tolerance") != NULL,
          "a negative touch tolerance refused", 0);
    bad.touch_tolerance_share = 1.0f;
    check(skinspheres_asset_load_file_with(join(dir, "set.ssb"), &bad, &missing) == SKINSPHERES_INVALID_ARGUMENT,
          "a touch tolerance of the whole height refused", 0);
    bad.touch_tolerance_share = (float)strtod("nan", NULL);
    check(skinspheres_asset_load_file_with(join(dir, "set.ssb"), &bad, &missing) == SKINSPHERES_INVALID_ARGUMENT,
          "a NaN touch tolerance refused", 0);
  }

  /* The set: binary from a file, JSON from memory (both with the options), and the fast-only
     binary (plain loader). */
  check(skinspheres_asset_load_file_with(join(dir, "set.ssb"), &options, &binary) == SKINSPHERES_OK, "load set.ssb", 0);
  json_text = (char*)read_all(join(dir, "set.json"), &json_size);
  check(json_text != NULL, "read set.json", 0);
  check(skinspheres_asset_load_memory_with(json_text, json_size, "set.json", &options, &json) == SKINSPHERES_OK,
        "load JSON from memory", 0);
  free(json_text); /* the asset holds its own copy */
  check(skinspheres_asset_narrow_margin(binary) == options.narrow_margin &&
            skinspheres_asset_narrow_margin(json) == options.narrow_margin,
        "the assets' margin is the options'", 0);
  touch_tolerance = skinspheres_asset_touch_tolerance(binary);
  check(touch_tolerance > 0.0f && touch_tolerance == skinspheres_asset_touch_tolerance(json) &&
            skinspheres_asset_touch_tolerance(NULL) == 0.0f,
        "the assets' touch tolerance: the default share of the rest height", 0);
  check(skinspheres_asset_load_file(join(dir, "set_fast.ssb"), &fast_only) == SKINSPHERES_OK, "load set_fast.ssb", 0);
  if (failures) return 1;
  check(skinspheres_asset_sphere_count(binary) == skinspheres_asset_sphere_count(json) &&
            skinspheres_asset_sphere_count(binary) > 10,
        "sphere counts", 0);
  check(skinspheres_asset_is_fast_only(fast_only) && !skinspheres_asset_is_fast_only(binary), "fast-only flags", 0);
  /* The contact rules, on triangles as the fitter states them, the same from every file (the fast-only
     file keeps them); the rest gap is a share of the rest height, as the touch tolerance is. */
  check(skinspheres_asset_contact_rules(binary) == SKINSPHERES_RULES_TRIANGLES &&
            skinspheres_asset_contact_rules(json) == SKINSPHERES_RULES_TRIANGLES &&
            skinspheres_asset_contact_rules(fast_only) == SKINSPHERES_RULES_TRIANGLES &&
            skinspheres_asset_contact_rules(NULL) == SKINSPHERES_RULES_SPHERE_PAIRS,
        "contact rules on triangles", 0);
  check(skinspheres_asset_contact_hops(binary) == 1 && skinspheres_asset_contact_hops(fast_only) == 1 &&
            skinspheres_asset_contact_hops(NULL) == 0,
        "contact hops 1", 0);
  check(skinspheres_asset_rest_gap(binary) > touch_tolerance && skinspheres_asset_rest_gap(binary) < 3 * touch_tolerance &&
            skinspheres_asset_rest_gap(json) == skinspheres_asset_rest_gap(binary) &&
            skinspheres_asset_rest_gap(fast_only) == skinspheres_asset_rest_gap(binary) &&
            skinspheres_asset_rest_gap(NULL) == 0.0f,
        "rest gap: 1% of the rest height, twice the default touch tolerance", 0);
  check(skinspheres_asset_has_triangle_contacts(binary) && skinspheres_asset_has_triangle_contacts(json) &&
            !skinspheres_asset_has_triangle_contacts(fast_only),
        "triangle contacts with the mesh only", 0);
  check(skinspheres_asset_vertex_count(binary) == vertex_count, "vertex count", 0);
  for (k = 0; k < skinspheres_asset_joint_count(binary); ++k) {
    check(strcmp(skinspheres_asset_joint_name(binary, k), skinspheres_asset_joint_name(json, k)) == 0, "joint names", 0);
  }

  /* The set matches the engine's character; a wrong vertex count is refused naming the file. */
  check(skinspheres_asset_check(binary, names, joint_count, vertex_count) == SKINSPHERES_OK, "asset_check", 0);
  check(skinspheres_asset_check(binary, names, joint_count, vertex_count + 1) == SKINSPHERES_MISMATCHED_ASSET,
        "asset_check wrong vertex count", 0);
  check(strstr(skinspheres_last_error(), "set.ssb") != NULL, "mismatch names the set file", 0);
  check(skinspheres_asset_check(binary, names + 1, joint_count - 1, vertex_count) == SKINSPHERES_MISMATCHED_ASSET,
        "asset_check missing joint", 0);
  /* The missing joint is named; a skeleton whose names repeat (RobotExpressive) is refused for that,
     naming the repeated joints, as soon as the list is not the set's own. */
  check(strstr(skinspheres_last_error(), names[0]) != NULL || strstr(skinspheres_last_error(), "more than once") != NULL,
        "missing joint named", 0);

  /* Instances in the engine's joint order. The assets are released at once: instances keep them. */
  check(skinspheres_instance_create(binary, names, joint_count, &a) == SKINSPHERES_OK, "instance a", 0);
  check(skinspheres_instance_create(json, names, joint_count, &b) == SKINSPHERES_OK, "instance b", 0);
  check(skinspheres_instance_create(fast_only, names, joint_count, &c) == SKINSPHERES_OK, "instance c", 0);
  check(skinspheres_instance_create(binary, NULL, 0, &in_set_order) == SKINSPHERES_OK, "instance in set order", 0);
  check(skinspheres_instance_create(binary, names, joint_count, &strided) == SKINSPHERES_OK, "instance strided", 0);
  check(skinspheres_instance_joint_count(a) == joint_count, "instance joint count", 0);
  /* A count no vector can hold is refused as out of memory, never an "internal error". */
  {
    skinspheres_instance* huge = NULL;
    check(skinspheres_instance_create(binary, names, SIZE_MAX, &huge) == SKINSPHERES_OUT_OF_MEMORY && huge == NULL,
          "SIZE_MAX joint names refused", 0);
    check(strstr(skinspheres_last_error(), "too large") != NULL, "the refusal says too large", 0);
    check(skinspheres_instance_reserve_contacts(a, SIZE_MAX) == SKINSPHERES_OUT_OF_MEMORY, "SIZE_MAX contacts refused", 0);
    check(strstr(skinspheres_last_error(), "too large") != NULL, "the refusal says too large", 0);
    check(skinspheres_instance_reserve_sphere_pairs(NULL, 8) == SKINSPHERES_INVALID_ARGUMENT,
          "null instance refused", 0);
    check(strstr(skinspheres_last_error(), "null instance") != NULL, "the null refusal says why", 0);
    check(skinspheres_instance_reserve_sphere_pairs(a, SIZE_MAX) == SKINSPHERES_OUT_OF_MEMORY,
          "SIZE_MAX sphere pairs refused", 0);
    check(strstr(skinspheres_last_error(), "too large") != NULL, "the sphere refusal says too large", 0);
    check(skinspheres_instance_reserve_sphere_pairs(c, 256) == SKINSPHERES_OK, "sphere pairs reserved", 0);
  }
  skinspheres_asset_release(json);
  skinspheres_asset_release(fast_only);
  if (failures) return 1;
  buffer = (skinspheres_sphere_pair*)malloc(capacity * sizeof(skinspheres_sphere_pair));
  part_buffer = (skinspheres_part_contact*)malloc(part_capacity * sizeof(skinspheres_part_contact));
  triangle_buffer = (skinspheres_triangle_contact*)malloc(triangle_capacity * sizeof(skinspheres_triangle_contact));
  check(skinspheres_instance_reserve_contacts(a, capacity) == SKINSPHERES_OK, "reserve", 0);
  sf.row_major = (float*)malloc(16 * sizeof(float) * joint_count);
  sf.interleaved = (unsigned char*)malloc(69 * (size_t)joint_count);
  sf.reversed = (float*)malloc(16 * sizeof(float) * joint_count);
  sf.vertices = (float*)malloc(8 * sizeof(float) * vertex_count);
  sf.vertices_reversed = (float*)malloc(3 * sizeof(float) * vertex_count);
  sphere_copy = (float*)malloc(4 * sizeof(float) * skinspheres_asset_sphere_count(binary));

  for (f = 0; f < frame_count; ++f) {
    const frame* fr = &frames[f];
    size_t count = 0, written = 0, in_place = 0;
    const skinspheres_sphere_pair* direct;
    int m;
    for (m = 0; m < 2; ++m) {
      skinspheres_instance* inst = m == 0 ? a : b;
      skinspheres_status st = m == 0 ? skinspheres_instance_update_fast(inst, fr->joint_world, joint_count)
                                     : skinspheres_instance_update_exact(inst, fr->positions, vertex_count,
                                                                         fr->joint_world, joint_count);
      check(st == SKINSPHERES_OK, m == 0 ? "update_fast" : "update_exact", f);
      check(skinspheres_instance_find_sphere_pairs(inst, &count) == SKINSPHERES_OK, "query", f);
      check(count == fr->contact_count[m], "contact count equals the C++ API's", f);
      /* Count first, then fill: a one-entry buffer is too small when there are more. */
      if (count > 1) {
        check(skinspheres_instance_get_sphere_pairs(inst, small, 1, &written) == SKINSPHERES_BUFFER_TOO_SMALL &&
                  written == count,
              "a small buffer is refused, the total count given", f);
        check(memcmp(&small[0], &fr->contacts[m][0], sizeof small[0]) == 0, "the first contact still copied", f);
      }
      check(skinspheres_instance_get_sphere_pairs(inst, buffer, capacity, &written) == SKINSPHERES_OK, "get_contacts", f);
      check(same_contacts(buffer, written, fr->contacts[m], fr->contact_count[m]),
            m == 0 ? "fast contacts equal the C++ API's" : "exact contacts equal the C++ API's", f);
      direct = skinspheres_instance_sphere_pairs(inst, &in_place);
      check(same_contacts(direct, in_place, buffer, written), "contacts in place", f);
      total[m] += count;
      triangle_total[m] += check_triangle_contacts(inst, fr, m, f, vertex_count, part_buffer, part_capacity,
                                                   triangle_buffer, triangle_capacity);
      for (k = 0; k < fr->triangle_count[m]; ++k) within_margin += fr->triangles[m][k].kind == SKINSPHERES_TRIANGLES_WITHIN_MARGIN;
    }
    make_strided(&sf, fr->joint_world, joint_count, fr->positions, vertex_count);
    check_strided(strided, fr, f, &sf, joint_count, vertex_count, sphere_copy, triangle_buffer, triangle_capacity);
    /* The fast-only set: the same fast contacts; exact mode refused with a clear message. */
    check(skinspheres_instance_update_fast(c, fr->joint_world, joint_count) == SKINSPHERES_OK, "fast-only update", f);
    check(skinspheres_instance_find_sphere_pairs(c, &count) == SKINSPHERES_OK, "fast-only query", f);
    direct = skinspheres_instance_sphere_pairs(c, &in_place);
    check(same_contacts(direct, in_place, fr->contacts[0], fr->contact_count[0]), "fast-only contacts", f);
    check(skinspheres_instance_find_contacts(c, NULL, 0, &count, NULL) == SKINSPHERES_VERSION_MISMATCH && count == 0,
          "triangle contacts from a fast-only set are refused", f);
    check(strstr(skinspheres_last_error(), "fast-only") != NULL, "that refusal says fast-only", f);
    check(skinspheres_instance_update_exact(c, fr->positions, vertex_count, fr->joint_world, joint_count) ==
              SKINSPHERES_INVALID_ARGUMENT,
          "exact mode on a fast-only set is refused", f);
    check(strstr(skinspheres_last_error(), "fast-only") != NULL, "the refusal says fast-only", f);
    check(skinspheres_instance_find_sphere_pairs(c, &count) != SKINSPHERES_OK && count == 0, "no contacts after a refused update", f);
  }

  /* A crowd on the engine's own loop, fast then exact: each instance as if alone. */
  {
    skinspheres_instance* crowd[3];
    skinspheres_frame_input inputs[3];
    const frame* fr = &frames[frame_count / 2];
    int m;
    crowd[0] = a;
    crowd[1] = b;
    crowd[2] = in_set_order;
    for (k = 0; k < 2; ++k) {
      inputs[k].joint_world = fr->joint_world;
      inputs[k].joint_count = joint_count;
      inputs[k].positions = fr->positions;
      inputs[k].vertex_count = vertex_count;
    }
    /* The set-order instance gets a joint list that does not fit it: it alone fails. */
    inputs[2] = inputs[0];
    inputs[2].joint_count = 3;
    for (m = 0; m < 2; ++m) {
      size_t n0, n1;
      const skinspheres_sphere_pair* c0;
      const skinspheres_sphere_pair* c1;
      const char* why = NULL;
      size_t written = 0;
      skinspheres_status st = skinspheres_crowd_update_and_find_contacts(
          crowd, inputs, 3, m == 0 ? SKINSPHERES_MODE_FAST : SKINSPHERES_MODE_EXACT, m == 0 ? reversed_parallel_for : NULL,
          &parallel_calls);
      check(st == SKINSPHERES_INVALID_DATA, "the crowd reports the failed instance", frame_count / 2);
      check(skinspheres_instance_status(in_set_order, &why) == SKINSPHERES_INVALID_ARGUMENT && why && why[0],
            "its own status says why", frame_count / 2);
      c0 = skinspheres_instance_sphere_pairs(a, &n0);
      c1 = skinspheres_instance_sphere_pairs(b, &n1);
      check(same_contacts(c0, n0, fr->contacts[m], fr->contact_count[m]) &&
                same_contacts(c1, n1, fr->contacts[m], fr->contact_count[m]),
            "crowd contacts equal the C++ API's", frame_count / 2);
      for (k = 0; k < 2; ++k) {
        check(skinspheres_instance_get_triangle_contacts(crowd[k], SKINSPHERES_ALL_PART_PAIRS, triangle_buffer,
                                                         triangle_capacity, &written) == SKINSPHERES_OK &&
                  same_triangles(triangle_buffer, written, fr->triangles[m], fr->triangle_count[m]),
              "crowd triangle contacts equal the C++ API's", frame_count / 2);
      }
    }
    check(parallel_calls == 3, "the engine's loop ran every instance", 0);
    /* The strided crowd calls: row-major matrices, interleaved positions; the same as packed. */
    {
      skinspheres_frame_input_strided strided_inputs[2];
      make_strided(&sf, fr->joint_world, joint_count, fr->positions, vertex_count);
      for (k = 0; k < 2; ++k) {
        strided_inputs[k].joint_world = k == 0 ? sf.row_major : sf.reversed + 16 * (joint_count - 1) + 3;
        strided_inputs[k].joint_count = joint_count;
        strided_inputs[k].joint_layout = k == 0 ? &row_major_layout : &reversed_layout;
        strided_inputs[k].positions = sf.vertices;
        strided_inputs[k].vertex_count = vertex_count;
        strided_inputs[k].position_stride = 32;
      }
      for (m = 0; m < 2; ++m) {
        size_t written = 0;
        const skinspheres_refit_mode mode = m == 0 ? SKINSPHERES_MODE_FAST : SKINSPHERES_MODE_EXACT;
        check(skinspheres_crowd_update_and_find_contacts_strided(crowd, strided_inputs, 2, mode, NULL, NULL) ==
                  SKINSPHERES_OK,
              "strided crowd with contacts", frame_count / 2);
        for (k = 0; k < 2; ++k) {
          size_t np = 0;
          const skinspheres_sphere_pair* pairs = skinspheres_instance_sphere_pairs(crowd[k], &np);
          check(same_contacts(pairs, np, fr->contacts[m], fr->contact_count[m]) &&
                    skinspheres_instance_get_triangle_contacts(crowd[k], SKINSPHERES_ALL_PART_PAIRS, triangle_buffer,
                                                               triangle_capacity, &written) == SKINSPHERES_OK &&
                    same_triangles(triangle_buffer, written, fr->triangles[m], fr->triangle_count[m]),
                "strided crowd: the C++ API's sphere pairs and triangle contacts", frame_count / 2);
        }
        check(skinspheres_crowd_update_and_find_sphere_pairs_strided(crowd, strided_inputs, 2, mode, reversed_parallel_for,
                                                                     &parallel_calls) == SKINSPHERES_OK,
              "strided crowd, sphere pairs", frame_count / 2);
        for (k = 0; k < 2; ++k) {
          size_t np = 0;
          const skinspheres_sphere_pair* pairs = skinspheres_instance_sphere_pairs(crowd[k], &np);
          check(same_contacts(pairs, np, fr->contacts[m], fr->contact_count[m]),
                "strided crowd: the C++ API's sphere pairs", frame_count / 2);
        }
      }
    }
    {
      /* The broad-phase-only crowd call through the engine's loop: its indices are blocks of
         instances (16 on an AVX-512 CPU, else 1), every instance run once, the same contacts. */
      int query_calls = 0;
      size_t n0, n1;
      const skinspheres_sphere_pair* c0;
      const skinspheres_sphere_pair* c1;
      check(skinspheres_crowd_update_and_find_sphere_pairs(crowd, inputs, 3, SKINSPHERES_MODE_FAST, reversed_parallel_for,
                                               &query_calls) == SKINSPHERES_INVALID_DATA,
            "the query-only crowd reports the failed instance", 0);
      check(query_calls == 1 || query_calls == 3, "one block of 16, or one call per instance", 0);
      c0 = skinspheres_instance_sphere_pairs(a, &n0);
      c1 = skinspheres_instance_sphere_pairs(b, &n1);
      check(same_contacts(c0, n0, fr->contacts[0], fr->contact_count[0]) &&
                same_contacts(c1, n1, fr->contacts[0], fr->contact_count[0]),
            "query-only crowd contacts equal the C++ API's", 0);
    }
    /* The broad-phase-only crowd call keeps no joint matrices: a find without positions is refused
       until an update that keeps them; the contacts are those of the crowd call with contacts. */
    {
      size_t n0 = 0;
      const skinspheres_sphere_pair* c0;
      const char* why = NULL;
      check(skinspheres_crowd_update_and_find_sphere_pairs(crowd, inputs, 2, SKINSPHERES_MODE_FAST, NULL, NULL) == SKINSPHERES_OK,
            "crowd query", frame_count / 2);
      c0 = skinspheres_instance_sphere_pairs(a, &n0);
      check(same_contacts(c0, n0, fr->contacts[0], fr->contact_count[0]), "crowd query contacts equal the C++ API's",
            frame_count / 2);
      check(skinspheres_instance_find_contacts(a, NULL, 0, NULL, NULL) == SKINSPHERES_INVALID_ARGUMENT,
            "no find without positions after the crowd query", frame_count / 2);
      check(skinspheres_instance_status(a, &why) == SKINSPHERES_INVALID_ARGUMENT && why &&
                strstr(why, "CrowdUpdateAndFindSpherePairs") != NULL,
            "and its status says why", frame_count / 2);
      check(skinspheres_instance_update_fast(a, fr->joint_world, joint_count) == SKINSPHERES_OK &&
                skinspheres_instance_find_contacts(a, NULL, 0, NULL, NULL) == SKINSPHERES_OK,
            "a find without positions after update_fast", frame_count / 2);
    }
  }

  skinspheres_instance_destroy(a);
  skinspheres_instance_destroy(b);
  skinspheres_instance_destroy(c);
  skinspheres_instance_destroy(in_set_order);
  skinspheres_instance_destroy(strided);
  free(sf.row_major);
  free(sf.interleaved);
  free(sf.reversed);
  free(sf.vertices);
  free(sf.vertices_reversed);
  free(sphere_copy);
  skinspheres_asset_release(binary);
  skinspheres_asset_release(NULL);
  skinspheres_instance_destroy(NULL);
  for (k = 0; k < joint_count; ++k) free((void*)names[k]);
  free(names);
  free(frames);
  free(frames_data);
  free(buffer);
  free(part_buffer);
  free(triangle_buffer);
  if (total[0] == 0 || total[1] == 0 || triangle_total[0] == 0 || triangle_total[1] == 0) {
    fprintf(stderr, "FAILED: no sphere or no triangle contacts in the clip, the comparison proves nothing\n");
    ++failures;
  }
  if (options.narrow_margin > 0 && within_margin == 0) {
    fprintf(stderr, "FAILED: a margin but no within-margin triangle pairs, the margin is not tested\n");
    ++failures;
  }
  if (part_kinds[1] == 0) {
    fprintf(stderr, "FAILED: no penetrating part pair, the classification is not tested\n");
    ++failures;
  }
  printf("C API (%s): %u frames, %lu fast and %lu exact sphere pairs, %lu fast and %lu exact triangle contacts "
         "(%lu within the margin %g), part pairs %lu touching and %lu penetrating, %s\n",
         skinspheres_version_string(), frame_count, (unsigned long)total[0], (unsigned long)total[1],
         (unsigned long)triangle_total[0], (unsigned long)triangle_total[1], (unsigned long)within_margin,
         (double)options.narrow_margin, part_kinds[0], part_kinds[1],
         failures ? "DIFFERENT from the C++ API" : "all equal to the C++ API's");
  return failures ? 1 : 0;
}
