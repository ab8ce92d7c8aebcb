# `skinspheres --version` prints "skinspheres VERSION" (the project's version) and exits 0; `--help`
# exits 0 and lists the commands.
include(${CMAKE_CURRENT_LIST_DIR}/tool_checks.cmake)
string(REPLACE "." "[.]" version_regex "${VERSION}")
expect_ok("^skinspheres ${version_regex}\n$" --version)
expect_ok("Subcommands:.*fit.*play" --help)
