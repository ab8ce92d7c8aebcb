# Included by the scripts that need the built-in character as a file: empties DIR and writes
# DIR/builtin.glb with `skinspheres export-builtin` (TOOL).
file(REMOVE_RECURSE ${DIR})
file(MAKE_DIRECTORY ${DIR})
execute_process(COMMAND ${TOOL} export-builtin ${DIR}/builtin.glb RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "export-builtin failed: ${rc}")
endif()
