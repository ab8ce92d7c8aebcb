# Retargeting and `check` run headless in CTest.
set(tool $<TARGET_FILE:skinspheres>)

# check on a library made by export-builtin: exit codes, a broken file among good ones, reports,
# 1 and 2 workers, rigs with other rest frames touching as the character's own clips, hostile maps.
add_test(NAME tool.check_library
  COMMAND ${CMAKE_COMMAND} -DTOOL=${tool} -DDIR=${PROJECT_BINARY_DIR}/test_tmp/check_library
          -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/check_library.cmake)
set_tests_properties(tool.check_library PROPERTIES TIMEOUT 600)

# Three workers over one Playback (also run under ThreadSanitizer by .ci/run).
add_test(NAME tool.check_parallel
  COMMAND ${CMAKE_COMMAND} -DTOOL=${tool} -DDIR=${PROJECT_BINARY_DIR}/test_tmp/check_parallel
          -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/check_parallel.cmake)
set_tests_properties(tool.check_parallel PROPERTIES TIMEOUT 600)

# Bone directions of clips played across the shared characters, against an independent sampler
# (tests/scripts/bone_directions.mjs, Node, no packages): within bounds for the transfer; the
# copy of local rotations must fail them (the check can fail).
find_program(NODE_EXECUTABLE NAMES node nodejs)
foreach(case "Soldier;Xbot;Walk" "Soldier;Xbot;Run" "Xbot;Soldier;Armature|mixamo.com|Layer0")
  list(GET case 0 source)
  list(GET case 1 target)
  list(GET case 2 clip)
  string(REGEX REPLACE "[^A-Za-z0-9]" "_" clip_id "${clip}")
  add_test(NAME tool.retarget_bone_directions.${source}_on_${target}.${clip_id}
    COMMAND ${CMAKE_COMMAND} -DTOOL=${tool} -DNODE=${NODE_EXECUTABLE}
            -DORACLE=${CMAKE_CURRENT_SOURCE_DIR}/scripts/bone_directions.mjs
            -DSOURCE=${SKINSPHERES_ASSET_DIR}/${source}.glb -DTARGET=${SKINSPHERES_ASSET_DIR}/${target}.glb
            "-DCLIP=${clip}" -DDIR=${PROJECT_BINARY_DIR}/test_tmp/bone_directions_${source}_${target}_${clip_id}
            -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/retarget_bone_directions.cmake)
  set_tests_properties(tool.retarget_bone_directions.${source}_on_${target}.${clip_id} PROPERTIES
    SKIP_REGULAR_EXPRESSION "asset absent" TIMEOUT 300)
endforeach()
