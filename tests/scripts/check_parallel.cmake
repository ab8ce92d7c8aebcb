# check with three workers on the built-in character and a rig of it with other rest frames: the
# clips' lines in order, exit 1 (the touch clips penetrate). Small enough for the ThreadSanitizer
# build (.ci/run), which watches the workers share one Playback.
#   cmake -DTOOL=... -DDIR=... -P check_parallel.cmake
include(${CMAKE_CURRENT_LIST_DIR}/builtin_glb.cmake)
include(${CMAKE_CURRENT_LIST_DIR}/tool_checks.cmake)
expect_exit(0 "wrote" export-builtin ${DIR}/rotated.glb --rotate-frames 3)
expect_exit(1 "  builtin/walk [^\n]*no penetration\n  builtin/touch [^\n]*PENETRATES[^\n]*\n  rotated/walk [^\n]*no penetration\n  rotated/touch [^\n]*PENETRATES"
            check ${DIR}/builtin.glb --clips ${DIR}/builtin.glb ${DIR}/rotated.glb --jobs 3)
