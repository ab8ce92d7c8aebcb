# Included by the scripts that need the built-in character as a file: empties DIR and writes
# DIR/builtin.glb with `skinspheres export-builtin` (TOOL).
file(REMOVE_RECURSE ${DIR})
file(MAKE_DIRECTORY ${DIR})
execute_process(COMMAND ${TOOL} export-builtin ${DIR}/builtin.glb RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "export-builtin failed: ${rc}")
endif()

# run_tool(<what> <arguments>...): runs TOOL with the arguments, its standard output in `out` (a
# macro, so in the caller's scope); a non-zero exit fails the test with "<what> failed" and the
# output.
macro(run_tool what)
  execute_process(COMMAND ${TOOL} ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed: ${rc}\n${out}")
  endif()
endmacro()
