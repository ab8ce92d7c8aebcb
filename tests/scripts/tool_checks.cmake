# Included by the scripts that run the tool (TOOL) and judge its exit code and output:
#   run_tool(<args>...)                  sets rc, out, err
#   expect_exit(<code> <regex> <args>...) exit <code> and stdout matching <regex>
#   expect_ok(<regex> <args>...)         expect_exit(0 ...)
#   expect_bad_input(<regex> <args>...)  exit 2 and stderr exactly one line "skinspheres: <regex>..."
# A failed expectation is a SEND_ERROR (the script goes on and fails at its end).
function(run_tool)
  execute_process(COMMAND ${TOOL} ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  set(rc "${rc}" PARENT_SCOPE)
  set(out "${out}" PARENT_SCOPE)
  set(err "${err}" PARENT_SCOPE)
endfunction()

function(expect_exit code regex)
  run_tool(${ARGN})
  if(NOT rc STREQUAL "${code}" OR NOT out MATCHES "${regex}")
    message(SEND_ERROR "skinspheres ${ARGN}: exit ${rc}, wanted ${code} and output matching \"${regex}\"\n${out}\n${err}")
  else()
    message(STATUS "ok (exit ${rc}): skinspheres ${ARGN}")
  endif()
  set(out "${out}" PARENT_SCOPE)
  set(err "${err}" PARENT_SCOPE)
endfunction()

function(expect_ok regex)
  expect_exit(0 "${regex}" ${ARGN})
endfunction()

function(expect_bad_input regex)
  run_tool(${ARGN})
  string(REGEX MATCHALL "\n" newlines "${err}")
  list(LENGTH newlines lines)
  if(NOT rc EQUAL 2 OR NOT lines EQUAL 1 OR NOT err MATCHES "^skinspheres: ${regex}[^\n]*\n$")
    message(SEND_ERROR "skinspheres ${ARGN}: exit ${rc}, ${lines} lines on stderr; wanted 2 and one line matching \"${regex}\":\n${err}")
  else()
    message(STATUS "ok: skinspheres ${ARGN}\n  ${err}")
  endif()
endfunction()
