# cmake -DBINARY_DIR=... -DTARGET=... -DEXPECT=REGEX -P expect_build_failure.cmake
# Builds TARGET in BINARY_DIR and succeeds only if the build fails with output matching
# EXPECT: a check that something the build must refuse is refused, for the right reason.
execute_process(COMMAND ${CMAKE_COMMAND} --build ${BINARY_DIR} --target ${TARGET}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc EQUAL 0)
  message(FATAL_ERROR "${TARGET} built, but the build must refuse it:\n${out}${err}")
endif()
if(NOT "${out}${err}" MATCHES "${EXPECT}")
  message(FATAL_ERROR "${TARGET} failed to build, but not with '${EXPECT}':\n${out}${err}")
endif()
message(STATUS "${TARGET} refused as expected ('${EXPECT}')")
