# `skinspheres colliders` (tests/scripts/colliders_vrm.cmake): each character's 32 colliders written
# as VRM, loaded by three.js with @pixiv/three-vrm-springbone (tests/vrm, pinned) and measured there
# over every frame of its clips at 10 fps. The figures are in docs/COLLIDERS.md.
find_program(NODE_EXECUTABLE NAMES node nodejs)
set(assets ${SKINSPHERES_ASSET_DIR})
# name | character (empty: the built-in one) | clips retargeted onto it | format | worst-pose coverage >= |
# mean standoff <=
set(collider_cases
  "builtin.vrm1|||vrm1|0.97|0.02"
  "builtin.vrm0|||vrm0|0.97|0.02"
  "CesiumMan.vrm1|${assets}/CesiumMan.glb||vrm1|0.97|0.02"
  "CesiumMan.vrm0|${assets}/CesiumMan.glb||vrm0|0.97|0.03"
  "Soldier.vrm1|${assets}/Soldier.glb||vrm1|0.97|0.02"
  # Xbot's own clip is one pose: Soldier's four clips give it motion.
  "Xbot_Soldier.vrm1|${assets}/Xbot.glb|${assets}/Soldier.glb|vrm1|0.97|0.02"
  # Its head is a rigid box a third of its height tall: round shapes leave 2.96% (docs/COLLIDERS.md).
  "RobotExpressive.vrm1|${assets}/RobotExpressive.glb||vrm1|0.97|0.035"
)
foreach(case ${collider_cases})
  string(REPLACE "|" ";" f "${case}")
  list(GET f 0 name)
  list(GET f 1 character)
  list(GET f 2 clips)
  list(GET f 3 format)
  list(GET f 4 min_covered)
  list(GET f 5 max_standoff)
  add_test(NAME tool.colliders.${name}
    COMMAND ${CMAKE_COMMAND} -DTOOL=$<TARGET_FILE:skinspheres> -DNODE=${NODE_EXECUTABLE}
            -DSCRIPT=${PROJECT_SOURCE_DIR}/tests/vrm/vrm_colliders.mjs -DCHARACTER=${character} -DCLIPS=${clips}
            -DFORMAT=${format}
            -DFPS=10 -DMIN_COVERED=${min_covered} -DMAX_STANDOFF=${max_standoff}
            -DDIR=${PROJECT_BINARY_DIR}/test_tmp/colliders_${name} -P ${PROJECT_SOURCE_DIR}/tests/scripts/colliders_vrm.cmake)
  set_tests_properties(tool.colliders.${name} PROPERTIES SKIP_REGULAR_EXPRESSION "asset absent" TIMEOUT 600)
endforeach()
