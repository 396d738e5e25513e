# Warnings and sanitizers for sceneloc's own targets only (never for dependencies).
#
# Under clang, the thread-safety analysis (common/util/thread_annotations.h) runs on every
# target and its findings are errors: a member annotated GUARDED_BY(mutex_) read or written
# without mutex_ held does not compile. scripts/sanitize.sh builds with clang, so CI checks
# it; g++ ignores the annotations.
function(sceneloc_target_options target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic)
  if(CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    target_compile_options(${target} PRIVATE -Wthread-safety -Werror=thread-safety)
  endif()
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
