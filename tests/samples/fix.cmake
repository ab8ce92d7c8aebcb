# `skinspheres fix` run headless in CTest (tests/scripts/fix_clips.cmake): the clip fails `check` at
# D before, its fixed GLB passes `check` at D after (exact contacts, through a glTF round trip), and,
# played, its bone directions and jerk are measured against the source's by independent scripts
# (tests/scripts/bone_directions.mjs, dump_jerk.mjs), within bounds where given.
set(tool $<TARGET_FILE:skinspheres>)
find_program(NODE_EXECUTABLE NAMES node nodejs)
set(assets ${SKINSPHERES_ASSET_DIR})
# name | character | clips file | clip | D | median | p95 | jerk ratio (empty: printed only)
set(fix_cases
  # The built-in touch clip: hands 2.2-2.3% of the height into the chest.
  "builtin|||touch|0.01|2|15|1.5"
  "RobotExpressive.Wave|${assets}/RobotExpressive.glb||Wave|0.01|2|15|1.5"
  "RobotExpressive.Yes|${assets}/RobotExpressive.glb||Yes|0.005|2|15|1.5"
  # Soldier's Walk on Xbot: both arms 2.8-2.9% into the chest on every frame; pulling them out
  # turns the arms by some 25 degrees (bone directions printed, not bounded).
  "Xbot_Soldier.Walk|${assets}/Xbot.glb|${assets}/Soldier.glb|Walk|0.01|||1.5"
  "Soldier_Xbot.Layer0|${assets}/Soldier.glb|${assets}/Xbot.glb|Armature|mixamo.com|Layer0|0.005|2|15|1.5"
)
foreach(case ${fix_cases})
  string(REPLACE "|" ";" f "${case}")
  list(GET f 0 name)
  list(GET f 1 character)
  list(GET f 2 clips)
  list(LENGTH f n)
  # A clip name may hold '|' (Armature|mixamo.com|Layer0): the fields after it are counted from the end.
  math(EXPR clip_fields "${n} - 7")
  list(SUBLIST f 3 ${clip_fields} clip_parts)
  list(JOIN clip_parts "|" clip)
  list(GET f -4 d)
  list(GET f -3 median)
  list(GET f -2 p95)
  list(GET f -1 jerk)
  add_test(NAME tool.fix.${name}
    COMMAND ${CMAKE_COMMAND} -DTOOL=${tool} -DNODE=${NODE_EXECUTABLE} -DORACLES=${CMAKE_CURRENT_SOURCE_DIR}/scripts
            -DCHARACTER=${character} -DCLIPS=${clips} "-DCLIP=${clip}" -DD=${d} -DMEDIAN=${median} -DP95=${p95}
            -DJERK=${jerk} -DDIR=${PROJECT_BINARY_DIR}/test_tmp/fix_${name} -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/fix_clips.cmake)
  set_tests_properties(tool.fix.${name} PROPERTIES SKIP_REGULAR_EXPRESSION "asset absent" TIMEOUT 600)
endforeach()
