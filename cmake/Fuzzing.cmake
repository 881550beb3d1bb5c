# SEMMAP_FUZZ=ON (clang, with SEMMAP_SANITIZE=address,undefined: the asan preset): every target
# below this point also gets libFuzzer's coverage instrumentation, and tests/fuzz builds
# fuzz_<name> from tests/fuzz/<name>_fuzz.cc per registered target, all under fuzz_all. The
# unit tests and the fuzzers share one build: the instrumentation costs the tests little, and a
# second sanitizer build of the same sources would cost CI minutes. scripts/fuzz.sh runs them.
option(SEMMAP_FUZZ "Also build the libFuzzer targets (clang, ASan + UBSan)" OFF)
if(SEMMAP_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "SEMMAP_FUZZ needs clang++ (libFuzzer); use `cmake --preset asan`")
  endif()
  if(NOT SEMMAP_SANITIZE MATCHES "address" OR NOT SEMMAP_SANITIZE MATCHES "undefined")
    message(FATAL_ERROR "SEMMAP_FUZZ runs under ASan and UBSan (any UB aborts, so the fuzzer "
                        "sees it as a crash): configure with SEMMAP_SANITIZE=address,undefined "
                        "(`cmake --preset asan`)")
  endif()
  message(STATUS "semmap: libFuzzer targets (fuzz_all)")
  # -Wno-unknown-warning-option: semmap_set_warnings' GCC-only -Wshadow=local.
  add_compile_options(-fsanitize=fuzzer-no-link -Wno-unknown-warning-option)
endif()

# semmap_add_fuzz_target(<name> [SOURCES extra.cc...] [LIBS lib...]): fuzz_<name> from
# tests/fuzz/<name>_fuzz.cc (LLVMFuzzerTestOneInput) plus SOURCES, linked with LIBS and
# libFuzzer's main; part of fuzz_all.
function(semmap_add_fuzz_target name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS" ${ARGN})
  if(NOT TARGET fuzz_all)
    add_custom_target(fuzz_all)
  endif()
  add_executable(fuzz_${name} ${name}_fuzz.cc ${ARG_SOURCES})
  target_include_directories(fuzz_${name} PRIVATE ${PROJECT_SOURCE_DIR})
  target_link_libraries(fuzz_${name} PRIVATE ${ARG_LIBS})
  target_link_options(fuzz_${name} PRIVATE -fsanitize=fuzzer)
  semmap_set_warnings(fuzz_${name})
  add_dependencies(fuzz_all fuzz_${name})
  set_property(GLOBAL APPEND PROPERTY SEMMAP_FUZZ_TARGETS ${name})
endfunction()

# <build>/fuzz_targets.txt: the registered targets, one a line (what scripts/fuzz.sh runs),
# written once the whole project is configured.
function(semmap_write_fuzz_targets)
  get_property(names GLOBAL PROPERTY SEMMAP_FUZZ_TARGETS)
  list(JOIN names "\n" text)
  file(WRITE ${PROJECT_BINARY_DIR}/fuzz_targets.txt "${text}\n")
endfunction()
if(SEMMAP_FUZZ)
  cmake_language(DEFER DIRECTORY ${CMAKE_SOURCE_DIR} CALL semmap_write_fuzz_targets)
endif()
