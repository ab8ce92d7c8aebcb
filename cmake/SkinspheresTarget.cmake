# skinspheres_library(<name> EXPORT <export set> [STAGE <subfolder>] [EXCLUDE_STAGES <subfolders...>]
#                     [PUBLIC_DEPS <targets...>] [PRIVATE_DEPS <targets...>])
# One library per top-level folder: sources are <folder>/src/**/*.cc (stage subfolders included),
# public headers live in <folder>/include/skinspheres/<folder>/ (subfolders mirror src/), built as
# skinspheres_<name> and exported as skinspheres::<name> in the given export set (one per package
# component, see the top-level CMakeLists.txt). PUBLIC_DEPS are linked publicly (their headers appear
# in ours), PRIVATE_DEPS privately.
# A stage folder can be its own target (lib's io/, the only user of Assimp): STAGE io builds only
# src/io/** and installs only include/skinspheres/<folder>/io/; the folder's own target names it in
# EXCLUDE_STAGES.

function(skinspheres_library name)
  cmake_parse_arguments(ARG "" "EXPORT;STAGE" "EXCLUDE_STAGES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  get_filename_component(folder ${CMAKE_CURRENT_SOURCE_DIR} NAME)
  set(src_dir ${CMAKE_CURRENT_SOURCE_DIR}/src)
  set(header_dir ${CMAKE_CURRENT_SOURCE_DIR}/include/)  # the trailing slash installs its contents
  set(header_dest ${CMAKE_INSTALL_INCLUDEDIR})
  if(ARG_STAGE)
    set(src_dir ${src_dir}/${ARG_STAGE})
    set(header_dir ${CMAKE_CURRENT_SOURCE_DIR}/include/skinspheres/${folder}/${ARG_STAGE})
    set(header_dest ${CMAKE_INSTALL_INCLUDEDIR}/skinspheres/${folder})
  endif()
  file(GLOB_RECURSE sources CONFIGURE_DEPENDS ${src_dir}/*.cc)
  set(header_excludes)
  foreach(stage ${ARG_EXCLUDE_STAGES})
    list(FILTER sources EXCLUDE REGEX "^${CMAKE_CURRENT_SOURCE_DIR}/src/${stage}/")
    list(APPEND header_excludes REGEX "/skinspheres/${folder}/${stage}$" EXCLUDE)
  endforeach()
  add_library(skinspheres_${name} ${sources})
  add_library(skinspheres::${name} ALIAS skinspheres_${name})
  set_target_properties(skinspheres_${name} PROPERTIES OUTPUT_NAME skinspheres_${name} EXPORT_NAME ${name})
  target_include_directories(skinspheres_${name} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
    $<BUILD_INTERFACE:${PROJECT_BINARY_DIR}/generated/include>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  # Internal headers by stage: "<stage>/<header>.h" from src/ (never installed).
  target_include_directories(skinspheres_${name} PRIVATE ${src_dir})
  target_link_libraries(skinspheres_${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  target_compile_features(skinspheres_${name} PUBLIC cxx_std_20)
  skinspheres_warnings(skinspheres_${name})
  install(TARGETS skinspheres_${name} EXPORT ${ARG_EXPORT}
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
    RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  install(DIRECTORY ${header_dir} DESTINATION ${header_dest} ${header_excludes})
endfunction()
