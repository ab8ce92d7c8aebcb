# The viewer page in a real browser: Debian's chromium, headless, software GL, driven by
# tests/viewer/page_tests.mjs (Node, DevTools protocol over a pipe). The tests skip (with
# "SKIPPED: chromium not found") only when chromium is absent; scripts/deps installs it.
set(viewer_dir ${PROJECT_BINARY_DIR}/test_tmp/viewer)
add_test(NAME viewer.pages
  COMMAND ${CMAKE_COMMAND} -DTOOL=$<TARGET_FILE:skinspheres> -DDIR=${viewer_dir}
          -P ${CMAKE_CURRENT_SOURCE_DIR}/viewer/make_pages.cmake)
set_tests_properties(viewer.pages PROPERTIES FIXTURES_SETUP viewer_pages)

find_program(NODE_EXECUTABLE NAMES node nodejs)
foreach(case play fit clips pieces fix colliders)
  if(NODE_EXECUTABLE)
    add_test(NAME viewer.${case}
      COMMAND ${NODE_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/viewer/page_tests.mjs ${case} ${viewer_dir})
  else()
    add_test(NAME viewer.${case} COMMAND ${CMAKE_COMMAND} -E false)
    message(WARNING "node not found: the viewer tests fail (scripts/deps installs Debian's nodejs)")
  endif()
  set_tests_properties(viewer.${case} PROPERTIES FIXTURES_REQUIRED viewer_pages TIMEOUT 180
    SKIP_REGULAR_EXPRESSION "SKIPPED: chromium not found")
endforeach()

# play --clips / fit on an animation file / --html / export-builtin options and their errors.
add_test(NAME tool.clip_files_and_pages
  COMMAND ${CMAKE_COMMAND} -DTOOL=$<TARGET_FILE:skinspheres> -DDIR=${PROJECT_BINARY_DIR}/test_tmp/clip_files_and_pages
          -P ${CMAKE_CURRENT_SOURCE_DIR}/scripts/clip_files_and_pages.cmake)
