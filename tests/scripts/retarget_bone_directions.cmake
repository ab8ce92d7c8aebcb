# One clip of SOURCE played on TARGET (shared characters), checked by the independent sampler
# ORACLE (bone_directions.mjs under NODE): the retarget's bone directions within a median of 3°
# and a 95th percentile of 20° (the bones whose rest directions differ between the rigs, shoulders
# and thumbs, keep that difference); the copy of local rotations must fail those bounds.
#   cmake -DTOOL= -DNODE= -DORACLE= -DSOURCE= -DTARGET= -DCLIP= -DDIR= -P retarget_bone_directions.cmake
if(NOT EXISTS ${SOURCE} OR NOT EXISTS ${TARGET})
  message(STATUS "asset absent: ${SOURCE} or ${TARGET}")
  return()
endif()
if(NOT NODE)
  message(FATAL_ERROR "node not found (scripts/deps installs Debian's nodejs)")
endif()
file(REMOVE_RECURSE ${DIR})
file(MAKE_DIRECTORY ${DIR})
foreach(mode auto copy)
  execute_process(COMMAND ${TOOL} play ${TARGET} --clips ${SOURCE} --clip ${CLIP} --retarget ${mode}
                          --dump ${DIR}/${mode}.jsonl
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "play --retarget ${mode}: exit ${rc}\n${out}\n${err}")
  endif()
  execute_process(COMMAND ${NODE} ${ORACLE} ${SOURCE} ${TARGET} ${DIR}/${mode}.jsonl ${CLIP} --max-median 3 --max-p95 20
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  message(STATUS "--retarget ${mode}: ${out}${err}")
  if(mode STREQUAL "auto" AND NOT rc EQUAL 0)
    message(FATAL_ERROR "the retarget is off: ${out}${err}")
  elseif(mode STREQUAL "copy" AND NOT rc EQUAL 1)
    message(FATAL_ERROR "the copy of local rotations passed (exit ${rc}): the check cannot tell\n${out}${err}")
  endif()
endforeach()
