# Builds TARGET in BUILD_DIR (cmake -P, from the test util/ThreadSafetyAnalysisRejects) and
# succeeds only when that build fails with each error that SOURCE names in an
# `// expect: MESSAGE` comment, reported as a thread-safety error on that comment's line.
# Anything else (the build succeeding, another error, a missing one) fails the test.
foreach(var BUILD_DIR TARGET SOURCE)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "expect_thread_safety_errors.cmake: -D${var}=... is required")
  endif()
endforeach()

# The expected errors: message and line.
file(STRINGS "${SOURCE}" source_lines)
set(expected "")
set(line_number 0)
foreach(line IN LISTS source_lines)
  math(EXPR line_number "${line_number} + 1")
  if(line MATCHES "// expect: (.*)$")
    list(APPEND expected "${line_number}|${CMAKE_MATCH_1}")
  endif()
endforeach()
list(LENGTH expected count)
if(count EQUAL 0)
  message(FATAL_ERROR "${SOURCE} names no expected error (// expect: ...)")
endif()

execute_process(
  COMMAND "${CMAKE_COMMAND}" --build "${BUILD_DIR}" --target "${TARGET}"
  RESULT_VARIABLE result
  OUTPUT_VARIABLE output
  ERROR_VARIABLE output)
if(result EQUAL 0)
  message(FATAL_ERROR "${TARGET} compiled, yet it holds ${count} thread-safety errors: the "
                      "analysis is off or not fatal (-Wthread-safety -Werror=thread-safety, "
                      "cmake/Warnings.cmake), or the annotations are empty. Output:\n${output}")
endif()

get_filename_component(file_name "${SOURCE}" NAME)
string(REGEX REPLACE "([][.*+?^$()|{}\\\\])" "\\\\\\1" file_pattern "${file_name}")
set(missing "")
foreach(entry IN LISTS expected)
  string(FIND "${entry}" "|" bar)
  string(SUBSTRING "${entry}" 0 ${bar} line)
  math(EXPR start "${bar} + 1")
  string(SUBSTRING "${entry}" ${start} -1 text)
  string(REGEX REPLACE "([][.*+?^$()|{}\\\\])" "\\\\\\1" text_pattern "${text}")
  set(pattern "${file_pattern}:${line}:[0-9]+: error: ${text_pattern}[^\n]*-Wthread-safety")
  if(NOT output MATCHES "${pattern}")
    string(APPEND missing "\n  line ${line}: ${text}")
  endif()
endforeach()
if(missing)
  message(FATAL_ERROR "${TARGET} failed to build, but without these thread-safety errors:"
                      "${missing}\nOutput:\n${output}")
endif()
message(STATUS "${TARGET}: all ${count} expected thread-safety errors reported")
