# A cross build (CMAKE_CROSSCOMPILING: cmake/toolchains/) takes the header-only packages, Eigen and
# nlohmann_json, from the build machine's Debian packages: their headers are the same for every
# target. They are not looked up through their CMake packages, which name /usr/include, the build
# machine's own system headers, as an include directory: a staging folder in the build tree holds
# links to just those two packages' headers, and imported targets of the usual names point there.
find_path(SKINSPHERES_HOST_EIGEN_DIR NAMES Eigen/Core PATHS /usr/include/eigen3 NO_DEFAULT_PATH NO_CMAKE_FIND_ROOT_PATH)
find_path(SKINSPHERES_HOST_JSON_DIR NAMES nlohmann/json.hpp PATHS /usr/include NO_DEFAULT_PATH NO_CMAKE_FIND_ROOT_PATH)
if(NOT SKINSPHERES_HOST_EIGEN_DIR OR NOT SKINSPHERES_HOST_JSON_DIR)
  message(FATAL_ERROR "a cross build needs the build machine's libeigen3-dev and nlohmann-json3-dev (scripts/deps)")
endif()
set(staging ${PROJECT_BINARY_DIR}/host_headers)
file(MAKE_DIRECTORY ${staging})
foreach(package Eigen unsupported)
  if(NOT EXISTS ${staging}/${package})
    file(CREATE_LINK ${SKINSPHERES_HOST_EIGEN_DIR}/${package} ${staging}/${package} SYMBOLIC)
  endif()
endforeach()
if(NOT EXISTS ${staging}/nlohmann)
  file(CREATE_LINK ${SKINSPHERES_HOST_JSON_DIR}/nlohmann ${staging}/nlohmann SYMBOLIC)
endif()
add_library(Eigen3::Eigen INTERFACE IMPORTED)
set_target_properties(Eigen3::Eigen PROPERTIES INTERFACE_INCLUDE_DIRECTORIES ${staging})
add_library(nlohmann_json::nlohmann_json INTERFACE IMPORTED)
set_target_properties(nlohmann_json::nlohmann_json PROPERTIES INTERFACE_INCLUDE_DIRECTORIES ${staging})
