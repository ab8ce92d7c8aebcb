# play keeps memory flat: playing the built-in walk for 30000 frames peaks within 16 bytes per
# extra frame of playing it for 3000 (each frame is summarised as it goes; no per-frame history).
# The peak of one process moves by up to ~450 KiB between identical runs (where the allocator and
# the thread pool's stacks land), as much as the limit: each length runs three times and the
# smallest peak counts, which a per-frame history would still raise in every run.
include(${CMAKE_CURRENT_LIST_DIR}/builtin_glb.cmake)
set(peaks "")
foreach(frames 3000 30000)
  set(lowest "")
  foreach(attempt 1 2 3)
    run_tool("play --frames ${frames}" play ${DIR}/builtin.glb --clip touch --frames ${frames})
    if(NOT out MATCHES "memory: peak ([0-9]+) KiB")
      message(FATAL_ERROR "play printed no peak memory:\n${out}")
    endif()
    if(lowest STREQUAL "" OR CMAKE_MATCH_1 LESS lowest)
      set(lowest ${CMAKE_MATCH_1})
    endif()
  endforeach()
  list(APPEND peaks ${lowest})
endforeach()
list(GET peaks 0 small)
list(GET peaks 1 large)
math(EXPR growth "${large} - ${small}")
math(EXPR limit "27000 * 16 / 1024")
if(growth GREATER limit)
  message(FATAL_ERROR "peak memory grew by ${growth} KiB from 3000 to 30000 frames (limit ${limit} KiB): per-frame history")
endif()
message(STATUS "peak ${small} KiB at 3000 frames, ${large} KiB at 30000 (growth ${growth} KiB, limit ${limit})")
