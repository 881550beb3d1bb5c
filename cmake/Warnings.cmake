# semmap_set_warnings(<target>): warnings on for our own targets only (no global flag edits).
# With clang, -Wthread-safety checks the annotations of common/thread_annotations.h: an error
# with SEMMAP_WERROR or SEMMAP_THREAD_SAFETY_WERROR (the tsan preset).
option(SEMMAP_THREAD_SAFETY_WERROR "clang: -Wthread-safety findings are errors" OFF)
function(semmap_set_warnings target)
  target_compile_options(${target} PRIVATE
    $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra -Wpedantic -Wnon-virtual-dtor -Wno-unused-parameter>)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    target_compile_options(${target} PRIVATE $<$<COMPILE_LANGUAGE:CXX>:-Wshadow=local>)
  endif()
  if(CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    target_compile_options(${target} PRIVATE $<$<COMPILE_LANGUAGE:CXX>:-Wthread-safety>)
    if(SEMMAP_THREAD_SAFETY_WERROR)
      target_compile_options(${target} PRIVATE $<$<COMPILE_LANGUAGE:CXX>:-Werror=thread-safety>)
    endif()
  endif()
  if(SEMMAP_WERROR)
    target_compile_options(${target} PRIVATE $<$<COMPILE_LANGUAGE:CXX>:-Werror>)
    if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
      # GCC 12 at -O2/-O3 reports std::function / std::variant members of option structs as
      # maybe-uninitialized and std::string concatenations as overlapping memcpy (GCC bugs
      # 105593, 105329): still printed, not fatal. clang's builds (tsan, fuzz) check these.
      target_compile_options(${target} PRIVATE
        $<$<COMPILE_LANGUAGE:CXX>:-Wno-error=maybe-uninitialized -Wno-error=restrict>)
    endif()
  endif()
endfunction()
