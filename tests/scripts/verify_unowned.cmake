# play --verify checks every triangle of the mesh: a sphere set in which one triangle is owned by
# no sphere fails (exit 1) and says so.
include(${CMAKE_CURRENT_LIST_DIR}/builtin_glb.cmake)
execute_process(COMMAND ${TOOL} fit ${DIR}/builtin.glb -o ${DIR}/set.json RESULT_VARIABLE rc OUTPUT_QUIET)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "fit failed: ${rc}")
endif()
file(READ ${DIR}/set.json set)
string(JSON removed GET "${set}" spheres 0 triangles 0)
string(JSON set REMOVE "${set}" spheres 0 triangles 0)
file(WRITE ${DIR}/unowned.json "${set}")
execute_process(COMMAND ${TOOL} play ${DIR}/builtin.glb --spheres ${DIR}/unowned.json --frames 3 --verify
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc EQUAL 0)
  message(FATAL_ERROR "--verify passed a set that leaves triangle ${removed} unowned:\n${out}")
endif()
if(NOT out MATCHES "1 triangles owned by no sphere" AND NOT err MATCHES "owned by no sphere|unowned|not owned")
  message(FATAL_ERROR "exit ${rc} but no word of the unowned triangle:\n${out}\n${err}")
endif()
# The untouched set passes.
execute_process(COMMAND ${TOOL} play ${DIR}/builtin.glb --spheres ${DIR}/set.json --frames 3 --verify
                RESULT_VARIABLE rc OUTPUT_VARIABLE out)
if(NOT rc EQUAL 0 OR NOT out MATCHES "0 triangles owned by no sphere")
  message(FATAL_ERROR "the fitted set should verify clean (exit ${rc}):\n${out}")
endif()
message(STATUS "unowned triangle ${removed} caught (exit ${rc})")
