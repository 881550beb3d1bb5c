# SEMMAP_SANITIZE=address,undefined adds the sanitizers to every target below this point.
set(SEMMAP_SANITIZE "" CACHE STRING "Comma-separated sanitizers (e.g. address,undefined)")
if(SEMMAP_SANITIZE)
  message(STATUS "semmap: sanitizers ${SEMMAP_SANITIZE}")
  add_compile_options(-fsanitize=${SEMMAP_SANITIZE} -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=${SEMMAP_SANITIZE})
endif()
