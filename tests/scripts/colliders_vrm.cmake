# One character through `skinspheres colliders --format FORMAT` (vrm1 or vrm0), then checked by
# tests/vrm/vrm_colliders.mjs: the file loaded by three.js with @pixiv/three-vrm-springbone, every
# collider attached to its joint's node, coverage and standoff measured there on every frame at
# FPS. Bounds: the worst pose covered at least MIN_COVERED, the mean standoff at most MAX_STANDOFF
# (shares of the height), the loader's figures within 0.002 of the report's, and (vrm1) ahead of
# the per-bone capsules at the same count (the report's "baseline": at least their coverage, at
# most their standoff).
# CLIPS (optional): an animation file whose clips are first retargeted onto the character and written
# with it (`skinspheres retarget`), so that the VRM file, and the loader, hold them.
#   cmake -DTOOL= -DNODE= -DSCRIPT= -DCHARACTER= [-DCLIPS=] -DFORMAT= -DFPS= -DMIN_COVERED= -DMAX_STANDOFF= -DDIR=
#         -P colliders_vrm.cmake
foreach(f ${CHARACTER} ${CLIPS})
  if(NOT EXISTS "${f}")
    message(STATUS "asset absent: ${f}")
    return()
  endif()
endforeach()
if(NOT NODE)
  message(FATAL_ERROR "node not found: the VRM check needs Node.js (scripts/deps installs nodejs)")
endif()
get_filename_component(script_dir "${SCRIPT}" DIRECTORY)
if(NOT EXISTS "${script_dir}/node_modules/@pixiv/three-vrm-springbone")
  message(FATAL_ERROR "${script_dir}/node_modules is missing: scripts/test installs it (npm ci --prefix tests/vrm)")
endif()
file(REMOVE_RECURSE "${DIR}")
file(MAKE_DIRECTORY "${DIR}")
set(input "${CHARACTER}")
if(NOT input)
  set(input "${DIR}/builtin.glb")
  execute_process(COMMAND "${TOOL}" export-builtin "${input}" RESULT_VARIABLE rc OUTPUT_QUIET)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "export-builtin failed (${rc})")
  endif()
endif()
if(CLIPS)
  execute_process(COMMAND "${TOOL}" retarget "${input}" --clips "${CLIPS}" -o "${DIR}/retargeted.glb" RESULT_VARIABLE rc
                  OUTPUT_QUIET)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "skinspheres retarget exited ${rc}")
  endif()
  set(input "${DIR}/retargeted.glb")
endif()
set(compare)
if(FORMAT STREQUAL "vrm1")
  set(compare --compare)
endif()
execute_process(COMMAND "${TOOL}" colliders "${input}" --format ${FORMAT} -o "${DIR}/out.vrm" --report "${DIR}/report.json"
                        --fps ${FPS} ${compare} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "skinspheres colliders exited ${rc}")
endif()
file(READ "${DIR}/report.json" report)
string(JSON covered GET "${report}" summary min_covered)
string(JSON standoff GET "${report}" summary mean_standoff_share)
if(FORMAT STREQUAL "vrm1")
  string(JSON base_covered GET "${report}" baseline per_bone_covering min_covered)
  string(JSON base_standoff GET "${report}" baseline per_bone_covering mean_standoff_share)
  message(STATUS "ours: covered ${covered}, standoff ${standoff}; per-bone capsules: covered ${base_covered}, standoff ${base_standoff}")
  if(covered LESS base_covered OR standoff GREATER base_standoff)
    message(FATAL_ERROR "not ahead of the per-bone capsules at the same count")
  endif()
endif()
execute_process(COMMAND "${NODE}" "${SCRIPT}" "${DIR}/out.vrm" "${DIR}/report.json" --fps ${FPS} --min-covered ${MIN_COVERED}
                        --max-standoff ${MAX_STANDOFF} --agree 0.002 RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the three-vrm check failed (${rc})")
endif()
