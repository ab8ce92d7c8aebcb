# cmake --install the build tree into a scratch prefix, then configure and build
# tests/install_consumer against it with find_package(skinspheres), and run it.
include(${CMAKE_CURRENT_LIST_DIR}/package_consumer.cmake)
file(REMOVE_RECURSE ${DIR})
install_package(${BUILD} ${DIR}/prefix)
build_consumer(${SOURCE} ${DIR}/build ${DIR}/prefix)
execute_process(COMMAND ${DIR}/build/consumer ${DIR}/no_such_set.json RESULT_VARIABLE rc OUTPUT_VARIABLE out)
if(NOT rc EQUAL 2 OR NOT out MATCHES "no_such_set.json: file not found")
  message(FATAL_ERROR "the consumer did not run as expected (${rc}): ${out}")
endif()
message(STATUS "find_package(skinspheres) consumer built and ran")
