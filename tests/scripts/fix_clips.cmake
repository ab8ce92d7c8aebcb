# `skinspheres fix` checked by measures of its own: CHARACTER's clip CLIP (the built-in character
# when CHARACTER is empty, exported first; with CLIPS, a file retargeted onto it by `retarget`
# first) must fail `check --max-depth D`; after `fix` at D, the written GLB must pass `check` at D
# (the exact contacts, through a glTF round trip), and, played, its bone directions against the
# source's (bone_directions.mjs: median, 95th percentile) and its jerk (dump_jerk.mjs) within
# MEDIAN, P95 and JERK when given (else printed only).
#   cmake -DTOOL= -DNODE= -DORACLES= [-DCHARACTER=] [-DCLIPS=] -DCLIP= -DD= [-DMEDIAN= -DP95=] [-DJERK=]
#         -DDIR= -P fix_clips.cmake
if((CHARACTER AND NOT EXISTS ${CHARACTER}) OR (CLIPS AND NOT EXISTS ${CLIPS}))
  message(STATUS "asset absent: ${CHARACTER} ${CLIPS}")
  return()
endif()
file(REMOVE_RECURSE ${DIR})
file(MAKE_DIRECTORY ${DIR})
function(run expect)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  message(STATUS "${ARGN}:\n${out}${err}")
  if(NOT rc EQUAL expect)
    message(FATAL_ERROR "exit ${rc}, expected ${expect}")
  endif()
endfunction()
set(source ${DIR}/source.glb)
if(NOT CHARACTER)
  run(0 ${TOOL} export-builtin ${source})
elseif(CLIPS)
  run(0 ${TOOL} retarget ${CHARACTER} --clips ${CLIPS} --clip ${CLIP} -o ${source})
else()
  configure_file(${CHARACTER} ${source} COPYONLY)
endif()
run(1 ${TOOL} check ${source} --clip ${CLIP} --max-depth ${D})
run(0 ${TOOL} fix ${source} --clip ${CLIP} --max-depth ${D} -o ${DIR}/fixed.glb --report ${DIR}/fix.json)
run(0 ${TOOL} check ${DIR}/fixed.glb --clip ${CLIP} --max-depth ${D})
run(0 ${TOOL} play ${source} --clip ${CLIP} --dump ${DIR}/source.jsonl)
run(0 ${TOOL} play ${DIR}/fixed.glb --clip ${CLIP} --dump ${DIR}/fixed.jsonl)
set(bounds)
if(MEDIAN)
  set(bounds --max-median ${MEDIAN} --max-p95 ${P95})
endif()
run(0 ${NODE} ${ORACLES}/bone_directions.mjs ${source} ${DIR}/fixed.glb ${DIR}/fixed.jsonl ${CLIP} ${bounds})
set(ratio)
if(JERK)
  set(ratio --max-ratio ${JERK})
endif()
run(0 ${NODE} ${ORACLES}/dump_jerk.mjs ${DIR}/source.jsonl ${DIR}/fixed.jsonl 30 ${ratio})
