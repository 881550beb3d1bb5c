# SEMMAP_SANITIZE=address,undefined adds the sanitizers to every target below this point.
set(SEMMAP_SANITIZE "" CACHE STRING "Comma-separated sanitizers (e.g. address,undefined)")
# A boolean true (ON, YES, 1) means the usual pair rather than "-fsanitize=ON".
if(SEMMAP_SANITIZE MATCHES "^(ON|on|On|YES|yes|TRUE|true|1)$")
  set(SEMMAP_SANITIZE "address,undefined")
endif()
if(SEMMAP_SANITIZE)
  message(STATUS "semmap: sanitizers ${SEMMAP_SANITIZE}")
  add_compile_options(-fsanitize=${SEMMAP_SANITIZE} -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=${SEMMAP_SANITIZE})
endif()
