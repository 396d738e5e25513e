# Warnings and sanitizers for sceneloc's own targets only (never for dependencies).
function(sceneloc_target_options target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic)
endfunction()

set(_sanitizers "")
if(ASAN)
  list(APPEND _sanitizers address)
endif()
if(UBSAN)
  list(APPEND _sanitizers undefined)
endif()
if(TSAN)
  list(APPEND _sanitizers thread)
endif()
if(_sanitizers)
  list(JOIN _sanitizers "," _san)
  add_compile_options(-fsanitize=${_san} -fno-omit-frame-pointer)
  add_link_options(-fsanitize=${_san})
  if(UBSAN)
    # Undefined behaviour stops the program (a failed test, a fuzzer crash), not a log line.
    add_compile_options(-fno-sanitize-recover=undefined)
  endif()
endif()

# Eigen's matrix products (the S_D hot loop) run about twice as fast with AVX2+FMA. The flag
# applies to every target of the project, never to some only: Eigen's alignment of heap
# matrices depends on it, and objects built with and without it must not share Eigen types.
if(SCENELOC_AVX2)
  add_compile_options(-mavx2 -mfma)
endif()
