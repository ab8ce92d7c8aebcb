# The public API's layout must not depend on the consumer's instruction-set flags.
# cmake --install the build tree (built for baseline x86-64) into a scratch prefix, then build
# tests/abi_consumer against it three times: with no extra flags, with -mavx2 -mfma, and with
# -march=native. Each runs one frame of every public job; all three must succeed and print the
# same thing (struct sizes, spheres, contacts). The wider builds must really be wider (stderr).
include(${CMAKE_CURRENT_LIST_DIR}/package_consumer.cmake)
file(REMOVE_RECURSE ${DIR})
install_package(${BUILD} ${DIR}/prefix)
set(reference "")
foreach(variant "baseline;-O2" "avx2;-mavx2 -mfma" "native;-march=native")
  list(GET variant 0 name)
  list(GET variant 1 flags)
  set(build ${DIR}/${name})
  build_consumer(${SOURCE} ${build} ${DIR}/prefix "-DSKINSPHERES_CONSUMER_FLAGS=${flags}")
  execute_process(COMMAND ${build}/abi_consumer ${build}/set.json RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "the ${name} consumer (${flags}) failed (${rc}):\n${out}\n${err}")
  endif()
  if(name STREQUAL "avx2" AND NOT err MATCHES "instruction set: avx")
    message(FATAL_ERROR "the avx2 consumer was not compiled for AVX2: ${err}")
  endif()
  if(reference STREQUAL "")
    set(reference "${out}")
  elseif(NOT out STREQUAL reference)
    message(FATAL_ERROR "the ${name} consumer (${flags}) differs from the baseline one:\n--- baseline\n${reference}\n--- ${name}\n${out}")
  endif()
  message(STATUS "${name} consumer (${flags}): ${err}")
endforeach()
message(STATUS "consumers built with baseline, AVX2 and native flags ran every public job alike")
