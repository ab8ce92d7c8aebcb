# cmake --install the build tree, then build two consumers against it, each asking only for its
# component and configured with every other package disabled:
#   tests/runtime_consumer (C++, COMPONENTS runtime): Assimp and nlohmann_json disabled;
#   tests/c_consumer (a C-only project, COMPONENTS c): Eigen3, TBB, Assimp and nlohmann_json disabled.
# Both load the built-in character's set (binary and JSON) and must report the same spheres and
# contacts in one pose.
include(${CMAKE_CURRENT_LIST_DIR}/package_consumer.cmake)
file(REMOVE_RECURSE ${DIR})
install_package(${BUILD} ${DIR}/prefix)
execute_process(COMMAND ${TOOL} fit "" -o ${DIR}/set.ssb RESULT_VARIABLE rc1 OUTPUT_QUIET)
execute_process(COMMAND ${TOOL} convert ${DIR}/set.ssb ${DIR}/set.json RESULT_VARIABLE rc2 OUTPUT_QUIET)
if(NOT rc1 EQUAL 0 OR NOT rc2 EQUAL 0)
  message(FATAL_ERROR "writing the built-in character's set failed")
endif()

# A package built without TBB must not need it (WITH_TBB: the build's SKINSPHERES_WITH_TBB).
set(no_tbb "")
if(NOT WITH_TBB)
  set(no_tbb -DCMAKE_DISABLE_FIND_PACKAGE_TBB=ON)
endif()
build_consumer(${SOURCE}/runtime_consumer ${DIR}/runtime_consumer ${DIR}/prefix ${no_tbb}
               -DCMAKE_DISABLE_FIND_PACKAGE_assimp=ON -DCMAKE_DISABLE_FIND_PACKAGE_nlohmann_json=ON)
build_consumer(${SOURCE}/c_consumer ${DIR}/c_consumer ${DIR}/prefix
               -DCMAKE_DISABLE_FIND_PACKAGE_Eigen3=ON -DCMAKE_DISABLE_FIND_PACKAGE_TBB=ON
               -DCMAKE_DISABLE_FIND_PACKAGE_assimp=ON -DCMAKE_DISABLE_FIND_PACKAGE_nlohmann_json=ON)

set(reference "")
foreach(run "runtime_consumer;set.ssb" "runtime_consumer;set.json" "c_consumer;set.ssb" "c_consumer;set.json")
  list(GET run 0 name)
  list(GET run 1 file)
  execute_process(COMMAND ${DIR}/${name}/${name} ${DIR}/${file} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${name} ${file} failed (${rc}):\n${out}\n${err}")
  endif()
  string(REGEX MATCH "spheres: [0-9]+, squashed-pose contacts: [1-9][0-9]*" found "${out}")
  if(NOT found)
    message(FATAL_ERROR "${name} ${file}: unexpected output\n${out}")
  endif()
  if(reference STREQUAL "")
    set(reference "${found}")
  elseif(NOT found STREQUAL reference)
    message(FATAL_ERROR "${name} ${file} found '${found}', the first consumer '${reference}'")
  endif()
  message(STATUS "${name} ${file}: ${out}")
endforeach()
# Without TBB: the loading program says its default loop is serial, and neither it nor the C API
# library links TBB.
if(NOT WITH_TBB)
  execute_process(COMMAND ${DIR}/runtime_consumer/runtime_consumer ${DIR}/set.ssb OUTPUT_VARIABLE out)
  if(NOT out MATCHES "default parallel loop: serial")
    message(FATAL_ERROR "a build without TBB runs its default loop on: ${out}")
  endif()
  file(GLOB c_library ${DIR}/prefix/lib*/libskinspheres_c.so)
  foreach(binary ${DIR}/runtime_consumer/runtime_consumer ${DIR}/c_consumer/c_consumer ${c_library})
    execute_process(COMMAND readelf -d ${binary} OUTPUT_VARIABLE dynamic RESULT_VARIABLE rc)
    if(NOT rc EQUAL 0 OR dynamic MATCHES "NEEDED[^\n]*libtbb" OR NOT dynamic MATCHES "NEEDED")
      message(FATAL_ERROR "${binary} links TBB (or readelf failed):
${dynamic}")
    endif()
    message(STATUS "${binary}: no TBB among its libraries")
  endforeach()
endif()
# A missing file: exit 2 and one line naming it.
execute_process(COMMAND ${DIR}/c_consumer/c_consumer ${DIR}/no_such.ssb RESULT_VARIABLE rc OUTPUT_VARIABLE out)
if(NOT rc EQUAL 2 OR NOT out MATCHES "no_such.ssb: file not found")
  message(FATAL_ERROR "the C consumer on a missing file (${rc}): ${out}")
endif()
message(STATUS "runtime and C components configured without the offline stack and agree: ${reference}")
