# The command-line tool runs headless in CTest.
set(tool $<TARGET_FILE:skinspheres>)

# demo: the walk touches nothing; in the touch clip the hands (real triangle contacts) reach the
# chest and then the head; --verify is clean.
add_test(NAME tool.demo COMMAND ${tool} demo --html ${PROJECT_BINARY_DIR}/tool_demo.html)
set_tests_properties(tool.demo PROPERTIES
  PASS_REGULAR_EXPRESSION "clip \"walk\"[^\n]*\n  no contacts.*hands on the chest: [0-9]+ frames.*hands on the head: [0-9]+ frames"
  FAIL_REGULAR_EXPRESSION "outside their sphere \\(first|differs from the brute-force oracle|[1-9][0-9]* triangles owned by no sphere")

add_test(NAME tool.export_builtin_refit
  COMMAND ${CMAKE_COMMAND} -DTOOL=${tool} -DDIR=${PROJECT_BINARY_DIR}/test_tmp/export_builtin
          -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/export_builtin_same_fit.cmake)

# --version: "skinspheres <project version>", exit 0 (a bare `skinspheres`: tests/samples/cli_errors.cmake).
add_test(NAME tool.version
  COMMAND ${CMAKE_COMMAND} -DTOOL=${tool} -DVERSION=${PROJECT_VERSION} -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/tool_version.cmake)

# Bad input: exit code 2 and one line naming the file.
add_test(NAME tool.missing_file COMMAND ${tool} fit ${PROJECT_BINARY_DIR}/no_such_file.glb)
set_tests_properties(tool.missing_file PROPERTIES WILL_FAIL TRUE)
add_test(NAME tool.missing_file_message COMMAND ${tool} fit ${PROJECT_BINARY_DIR}/no_such_file.glb)
set_tests_properties(tool.missing_file_message PROPERTIES
  PASS_REGULAR_EXPRESSION "no_such_file.glb: file not found|no_such_file.glb: .*not")

# Every clip of every shared character plays with --verify clean, in both refit modes.
set(margin_CesiumMan 0.015)  # about 1% of each body's height, in its own units
set(margin_RobotExpressive 0.045)
set(margin_Soldier 0.002)
set(margin_Xbot 0.018)
foreach(asset CesiumMan RobotExpressive Soldier Xbot)
  set(file ${SKINSPHERES_ASSET_DIR}/${asset}.glb)
  # The refitted radius over the smallest one around the same centre that holds the sphere's
  # skinned triangles: 1.000 in exact mode (the exact radius is that one, plus a rounding margin),
  # never below 1 in fast mode.
  set(radius_exact "radius / needed: mean (0[.]|1[.]00[1-9]|1[.]0[1-9]|1[.][1-9]|[2-9])")
  set(radius_fast "radius / needed: mean 0[.]")
  foreach(mode exact fast)
    add_test(NAME tool.verify.${asset}.${mode}
      COMMAND ${tool} play ${file} --clip all --verify --mode ${mode} --fps 15)
    set_tests_properties(tool.verify.${asset}.${mode} PROPERTIES
      PASS_REGULAR_EXPRESSION "verify: 0 triangle-frames outside their sphere over [0-9]+ clips. narrow phase differs from the oracle in 0 frames"
      FAIL_REGULAR_EXPRESSION "[1-9][0-9]* triangles owned by no sphere;${radius_${mode}}"
      SKIP_REGULAR_EXPRESSION "file not found"
      TIMEOUT 600)
  endforeach()
  # With triangle pieces (docs/TRIANGLE_PIECES.md): every piece inside its sphere on every frame,
  # the narrow phase (pieces tested, triangles reported) equal to the oracle, in both modes.
  foreach(mode exact fast)
    add_test(NAME tool.verify.${asset}.pieces.${mode}
      COMMAND ${tool} play ${file} --clip all --verify --mode ${mode} --fps 5 --piece-edge 0.03)
    set_tests_properties(tool.verify.${asset}.pieces.${mode} PROPERTIES
      PASS_REGULAR_EXPRESSION "verify: 0 triangle-frames outside their sphere over [0-9]+ clips. narrow phase differs from the oracle in 0 frames"
      FAIL_REGULAR_EXPRESSION "[1-9][0-9]* triangles owned by no sphere;${radius_${mode}}"
      SKIP_REGULAR_EXPRESSION "file not found"
      TIMEOUT 600)
  endforeach()
  # With a margin (about 1% of the body height): pairs of spheres that do not overlap can hold
  # triangles nearer than it; CharacterInstance::FindContacts queries the spheres grown by half the
  # margin, so the narrow phase still equals the oracle (it missed them before, 2026-12-06).
  foreach(mode exact fast)
    add_test(NAME tool.verify.${asset}.margin.${mode}
      COMMAND ${tool} play ${file} --clip all --verify --mode ${mode} --fps 5 --margin ${margin_${asset}})
    set_tests_properties(tool.verify.${asset}.margin.${mode} PROPERTIES
      PASS_REGULAR_EXPRESSION "verify: 0 triangle-frames outside their sphere over [0-9]+ clips. narrow phase differs from the oracle in 0 frames"
      SKIP_REGULAR_EXPRESSION "file not found"
      TIMEOUT 600)
  endforeach()
  add_test(NAME tool.fit.${asset} COMMAND ${tool} fit ${file} -o ${PROJECT_BINARY_DIR}/test_tmp/${asset}.spheres.json)
  set_tests_properties(tool.fit.${asset} PROPERTIES
    PASS_REGULAR_EXPRESSION "triangles covered: [0-9]+ of [0-9]+ [(]bind-pose check[)]"
    SKIP_REGULAR_EXPRESSION "file not found")
endforeach()

if(TARGET hello_world)
  add_test(NAME sample.hello_world COMMAND hello_world)
  set_tests_properties(sample.hello_world PROPERTIES
    PASS_REGULAR_EXPRESSION "t=1.2 s: [1-9][0-9]* sphere pairs, 2 touching part pairs  \\[torso - arm_l: [1-9][0-9]* triangle pairs")
endif()

# A clip that is not there: exit 2 and the list of clips.
add_test(NAME tool.unknown_clip COMMAND ${tool} play ${SKINSPHERES_ASSET_DIR}/Soldier.glb --clip Dance)
set_tests_properties(tool.unknown_clip PROPERTIES
  PASS_REGULAR_EXPRESSION "Soldier.glb: no clip \"Dance\"; clips: 0:.*Walk"
  SKIP_REGULAR_EXPRESSION "file not found")

# --dump writes one JSON line per frame with spheres, pairs, contacts and clip_time; --report a
# JSON summary (built-in character).
add_test(NAME tool.play_dump
  COMMAND ${CMAKE_COMMAND} -DTOOL=${tool} -DDIR=${PROJECT_BINARY_DIR}/test_tmp/play_dump
          -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/play_dump.cmake)

# play keeps memory flat over long runs (no per-frame history): tests/samples/play_memory_tests.cc,
# which counts the live heap frame by frame.

# A version-1 sphere set plays, with the character's mesh for the triangle tests.
add_test(NAME tool.play_v1_set
  COMMAND ${CMAKE_COMMAND} -DTOOL=${tool} -DDIR=${PROJECT_BINARY_DIR}/test_tmp/play_v1
          -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/play_v1_set.cmake)

# --verify checks every triangle of the mesh, owned or not.
add_test(NAME tool.verify_unowned_triangle
  COMMAND ${CMAKE_COMMAND} -DTOOL=${tool} -DDIR=${PROJECT_BINARY_DIR}/test_tmp/verify_unowned
          -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/verify_unowned.cmake)

# Out-of-range numbers are refused with one line, never an abort.
foreach(case "clip_index;--clip;99999999999999999999999" "frames;--frames;2000000000")
  list(GET case 0 name)
  list(GET case 1 flag)
  list(GET case 2 value)
  add_test(NAME tool.refuses_${name} COMMAND ${tool} play ${SKINSPHERES_ASSET_DIR}/CesiumMan.glb ${flag} ${value})
  set_tests_properties(tool.refuses_${name} PROPERTIES
    PASS_REGULAR_EXPRESSION "skinspheres: .*CesiumMan.glb: (no clip|clip .* would play)"
    SKIP_REGULAR_EXPRESSION "file not found")
endforeach()

# play --export-glb writes the character plus one animated sphere per fitted sphere.
add_test(NAME tool.play_export_glb
  COMMAND ${CMAKE_COMMAND} -DTOOL=${tool} -DASSET=${SKINSPHERES_ASSET_DIR}/CesiumMan.glb
          -DDIR=${PROJECT_BINARY_DIR}/test_tmp/play_export -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/play_export_glb.cmake)
set_tests_properties(tool.play_export_glb PROPERTIES SKIP_REGULAR_EXPRESSION "asset absent")

# fit -o .json / .ssb and convert both ways, bit-exact, on the built-in character and on Xbot.
foreach(input "builtin;" "Xbot;${SKINSPHERES_ASSET_DIR}/Xbot.glb")
  list(GET input 0 name)
  list(LENGTH input n)
  set(file "")
  if(n GREATER 1)
    list(GET input 1 file)
  endif()
  add_test(NAME tool.convert_round_trip.${name}
    COMMAND ${CMAKE_COMMAND} -DTOOL=${tool} "-DINPUT=${file}" -DDIR=${PROJECT_BINARY_DIR}/test_tmp/convert_${name}
            -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/convert_round_trip.cmake)
  set_tests_properties(tool.convert_round_trip.${name} PROPERTIES SKIP_REGULAR_EXPRESSION "asset absent" TIMEOUT 600)
endforeach()

# The installed package: find_package(skinspheres) and skinspheres::runtime alone (not in a
# sanitizer build: the consumer is built without the sanitizer runtime).
if(NOT SKINSPHERES_SANITIZE)
add_test(NAME package.find_package_consumer
  COMMAND ${CMAKE_COMMAND} -DBUILD=${PROJECT_BINARY_DIR} -DSOURCE=${CMAKE_CURRENT_SOURCE_DIR}/install_consumer
          -DDIR=${PROJECT_BINARY_DIR}/test_tmp/install_consumer -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/install_consumer.cmake)
set_tests_properties(package.find_package_consumer PROPERTIES TIMEOUT 300)
# The same package, consumed by programs built for AVX2 and for this machine: same layouts, same
# results, no crash.
add_test(NAME package.abi_consumers
  COMMAND ${CMAKE_COMMAND} -DBUILD=${PROJECT_BINARY_DIR} -DSOURCE=${CMAKE_CURRENT_SOURCE_DIR}/abi_consumer
          -DDIR=${PROJECT_BINARY_DIR}/test_tmp/abi_consumers -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/abi_consumers.cmake)
set_tests_properties(package.abi_consumers PROPERTIES TIMEOUT 900)
# Components: COMPONENTS runtime configures with Assimp and nlohmann_json disabled; COMPONENTS c
# from a C-only project with Eigen, TBB and Assimp disabled; both load a set and agree.
add_test(NAME package.component_consumers
  COMMAND ${CMAKE_COMMAND} -DBUILD=${PROJECT_BINARY_DIR} -DTOOL=${tool} -DSOURCE=${CMAKE_CURRENT_SOURCE_DIR}
          -DWITH_TBB=${SKINSPHERES_WITH_TBB} -DDIR=${PROJECT_BINARY_DIR}/test_tmp/component_consumers
          -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/component_consumers.cmake)
set_tests_properties(package.component_consumers PROPERTIES TIMEOUT 600)
endif()
