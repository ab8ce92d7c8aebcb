/* Loads a sphere set through the installed C API, runs one fast frame in a pose made from the set's
   own rest pose and prints what it found (the test compares it with the C++ runtime consumer's). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "skinspheres/skinspheres.h"

int main(int argc, char** argv) {
  skinspheres_asset* asset = NULL;
  skinspheres_instance* instance = NULL;
  skinspheres_status st;
  size_t joints, j, contacts = 0;
  float* rest;
  printf("skinspheres C API: headers %s, library %s\n", SKINSPHERES_VERSION_STRING, skinspheres_version_string());
  if (skinspheres_version() != SKINSPHERES_VERSION) return 1;
  st = skinspheres_asset_load_file(argc > 1 ? argv[1] : "missing.ssb", &asset);
  if (st != SKINSPHERES_OK) {
    printf("%s: %s\n", skinspheres_status_string(st), skinspheres_last_error());
    return 2;
  }
  if (skinspheres_instance_create(asset, NULL, 0, &instance) != SKINSPHERES_OK) {
    printf("%s\n", skinspheres_last_error());
    return 1;
  }
  joints = skinspheres_asset_joint_count(asset);
  rest = (float*)malloc(16 * sizeof(float) * joints);
  /* The rest pose with every joint's translation halved (as the C++ consumer does). */
  for (j = 0; j < joints; ++j) {
    memcpy(rest + 16 * j, skinspheres_asset_joint_rest_world(asset, j), 16 * sizeof(float));
    rest[16 * j + 12] *= 0.5f;
    rest[16 * j + 13] *= 0.5f;
    rest[16 * j + 14] *= 0.5f;
  }
  if (skinspheres_instance_update_fast(instance, rest, joints) != SKINSPHERES_OK ||
      skinspheres_instance_find_sphere_pairs(instance, &contacts) != SKINSPHERES_OK) {
    printf("%s\n", skinspheres_last_error());
    return 1;
  }
  printf("spheres: %lu, squashed-pose contacts: %lu\n", (unsigned long)skinspheres_asset_sphere_count(asset),
         (unsigned long)contacts);
  free(rest);
  skinspheres_instance_destroy(instance);
  skinspheres_asset_release(asset);
  return 0;
}
