# Helpers for the scripts that test the installed package (include() them, then call):
#   install_package(BUILD PREFIX)                     cmake --install BUILD --prefix PREFIX
#   build_consumer(SOURCE BINARY PREFIX [ARGS...])    configure SOURCE into BINARY against PREFIX
#                                                     (Release, extra configure ARGS) and build it
# Either stops the script with the tool's output on failure.
function(install_package build prefix)
  execute_process(COMMAND ${CMAKE_COMMAND} --install ${build} --prefix ${prefix} RESULT_VARIABLE rc OUTPUT_QUIET)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "cmake --install failed: ${rc}")
  endif()
endfunction()

function(build_consumer source binary prefix)
  execute_process(COMMAND ${CMAKE_COMMAND} -S ${source} -B ${binary} -DCMAKE_PREFIX_PATH=${prefix}
                          -DCMAKE_BUILD_TYPE=Release ${ARGN}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "configuring ${source} (${ARGN}) failed:\n${out}\n${err}")
  endif()
  execute_process(COMMAND ${CMAKE_COMMAND} --build ${binary} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "building ${source} failed:\n${out}\n${err}")
  endif()
endfunction()
