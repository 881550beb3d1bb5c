# SEMMAP_SANITIZE=address,undefined (or thread) adds the sanitizers to every target below this
# point. ThreadSanitizer cannot be combined with AddressSanitizer or LeakSanitizer.
set(SEMMAP_SANITIZE "" CACHE STRING
    "Comma-separated sanitizers (address,undefined or thread[,undefined])")
# A boolean true (ON, YES, 1) means the usual pair rather than "-fsanitize=ON".
if(SEMMAP_SANITIZE MATCHES "^(ON|on|On|YES|yes|TRUE|true|1)$")
  set(SEMMAP_SANITIZE "address,undefined")
endif()
if(SEMMAP_SANITIZE)
  string(REPLACE "," ";" _semmap_sanitizers "${SEMMAP_SANITIZE}")
  if("thread" IN_LIST _semmap_sanitizers AND
     ("address" IN_LIST _semmap_sanitizers OR "leak" IN_LIST _semmap_sanitizers))
    message(FATAL_ERROR "SEMMAP_SANITIZE=${SEMMAP_SANITIZE}: thread cannot be combined with "
                        "address or leak (use separate builds: the asan and tsan presets)")
  endif()
  message(STATUS "semmap: sanitizers ${SEMMAP_SANITIZE}")
  add_compile_options(-fsanitize=${SEMMAP_SANITIZE} -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=${SEMMAP_SANITIZE})
  if("thread" IN_LIST _semmap_sanitizers)
    # Default options and the suppressions file, compiled into every executable below. (Not
    # named semmap_*: it is build plumbing, outside the core layer rule of CoreLayers.cmake.)
    set(_semmap_tsan_supp ${CMAKE_CURRENT_LIST_DIR}/tsan.supp)
    set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${_semmap_tsan_supp})
    file(READ ${_semmap_tsan_supp} SEMMAP_TSAN_SUPPRESSIONS)
    configure_file(${CMAKE_CURRENT_LIST_DIR}/tsan_defaults.cc.in
                   ${CMAKE_BINARY_DIR}/tsan_defaults.cc @ONLY)
    add_library(tsan_defaults OBJECT ${CMAKE_BINARY_DIR}/tsan_defaults.cc)
    link_libraries(tsan_defaults)
  endif()
endif()
