# Compile and link flags, chosen per compiler: GCC and Clang on one side, MSVC (and clang-cl) on
# the other. No flag of one family reaches the other, so a Visual Studio configure sees only MSVC
# options.
#
# skinspheres_warnings(<target>)       the project's warnings, as errors with SKINSPHERES_WERROR
# skinspheres_simd_avx2(<target>)      compile the whole target for AVX2 (SKINSPHERES_AVX2=ON)
# skinspheres_test_program(<target>)   a test program's own code: quicker to compile (below)
# skinspheres_hide_static_libs(<lib>)  a shared library exports none of its static dependencies'
#                                      symbols and has no undefined symbol left (ELF)
#
# Everywhere: no floating-point contraction. A compiler that fuses a*b+c into one FMA rounds once
# where the source rounds twice, and only where it chooses to: GCC does by default in C++ (on
# aarch64 always, on x86-64 inside any function compiled with FMA), clang within expressions. The
# per-frame code must give the same bits on every platform and at every instruction set
# (skinning/include/skinspheres/skinning/platform.h), and the narrow phase's exact predicates
# rely on every product and sum being rounded on its own. MSVC's /fp:precise does not contract.
if(MSVC)
  set(SKINSPHERES_COMPILER_MSVC ON)
else()
  set(SKINSPHERES_COMPILER_MSVC OFF)
endif()

if(SKINSPHERES_COMPILER_MSVC)
  add_compile_options(/fp:precise /utf-8 /permissive- /Zc:__cplusplus /EHsc)
  add_compile_definitions(_CRT_SECURE_NO_WARNINGS NOMINMAX)
else()
  add_compile_options(-ffp-contract=off)
  # Eigen's NEON code fuses its multiply-adds (vfmaq) whenever the compiler says the target has
  # FMA, which every aarch64 does; its SSE code never does. Hiding the feature macro makes Eigen take
  # its unfused path (vmlaq: a multiply, then an add), so Eigen's products round as on x86-64.
  if(CMAKE_SYSTEM_PROCESSOR MATCHES "^(aarch64|arm64|ARM64)$")
    add_compile_options(-U__ARM_FEATURE_FMA)
  endif()
endif()

function(skinspheres_warnings target)
  if(SKINSPHERES_COMPILER_MSVC)
    target_compile_options(${target} PRIVATE /W4)
    if(SKINSPHERES_WERROR)
      target_compile_options(${target} PRIVATE /WX)
    endif()
    return()
  endif()
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")  # clang (fuzz builds) has no such warning
    target_compile_options(${target} PRIVATE -Wno-maybe-uninitialized)
  endif()
  if(SKINSPHERES_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

# skinspheres_test_program(<target>): a test program's own file (the assertions, oracles and
# fixtures around the code it checks) is compiled for build time, not speed. The libraries' own files
# keep their flags.
#  - Release: -O1 instead of -O3, about 30% less compile time per file (GCC 12, aarch64 and x86-64).
#    -ffp-contract=off holds at every level and nothing uses fast-math, so results do not change.
#  - UBSan builds: without the alignment, null and pointer-overflow checks in the test's own file.
#    On gtest-heavy files they double GCC's compile time (fast_bound_tests 42 s -> 21 s,
#    sphere_set_binary_tests 54 s -> 29 s).
# The limit of both: code a test file and a library both instantiate (header-inline functions,
# templates such as std::vector's, destructors) is linked once, and the linker keeps the copy it
# meets first, the test file's. So a library call into such code may run the -O1 copy, or in the
# UBSan tree the copy without those three checks. Code defined in the libraries' own .cc files
# always runs as compiled there, with every check.
function(skinspheres_test_program target)
  if(SKINSPHERES_COMPILER_MSVC)
    return()
  endif()
  if(CMAKE_BUILD_TYPE STREQUAL "Release" AND NOT SKINSPHERES_SANITIZE AND NOT SKINSPHERES_FUZZ)
    target_compile_options(${target} PRIVATE -O1)
  endif()
  if(SKINSPHERES_SANITIZE MATCHES "undefined")
    target_compile_options(${target} PRIVATE -fno-sanitize=alignment,null,pointer-overflow)
  endif()
endfunction()

function(skinspheres_simd_avx2 target)
  target_compile_definitions(${target} PRIVATE SKINSPHERES_AVX2=1)
  if(SKINSPHERES_COMPILER_MSVC)
    target_compile_options(${target} PRIVATE /arch:AVX2)
  else()
    target_compile_options(${target} PRIVATE -mavx2 -mfma)
  endif()
endfunction()

function(skinspheres_hide_static_libs target)
  if(CMAKE_SYSTEM_NAME STREQUAL "Linux" AND NOT SKINSPHERES_COMPILER_MSVC)
    target_link_options(${target} PRIVATE -Wl,--exclude-libs,ALL)
    if(NOT SKINSPHERES_SANITIZE)
      target_link_options(${target} PRIVATE -Wl,--no-undefined)
    endif()
  endif()
  # Windows: a DLL exports only what is marked __declspec(dllexport) (skinspheres.h), and links
  # only when every symbol is resolved.
endfunction()
