# capi_reference (C++) writes the built-in character's set and clip with the C++ API's contacts;
# capi_contacts (C99) replays the clip through the C API and compares. MARGIN (optional): the
# narrow phase's margin, given to both (the C API through skinspheres_asset_options).
file(REMOVE_RECURSE ${DIR})
execute_process(COMMAND ${REFERENCE} ${DIR} ${MARGIN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "capi_reference failed (${rc}):\n${out}\n${err}")
endif()
message(STATUS "${out}")
execute_process(COMMAND ${PROGRAM} ${DIR} ${MARGIN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT out MATCHES "all equal to the C\\+\\+ API's")
  message(FATAL_ERROR "capi_contacts failed (${rc}):\n${out}\n${err}")
endif()
message(STATUS "${out}")
