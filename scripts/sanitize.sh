#!/usr/bin/env bash
# Builds the test suite with AddressSanitizer + UndefinedBehaviorSanitizer (clang, -O1
# -g1) into ./build-asan and runs it: any memory error, leak or undefined behaviour fails
# the test it happens in. Extra arguments go to ctest. CI runs it after scripts/test.sh.
#
# Clang, so that this is also CI's clang build: the thread-safety analysis is an error
# there (cmake/Warnings.cmake; a member GUARDED_BY a mutex touched without it does not
# compile), and util/ThreadSafetyAnalysisRejects checks that it still rejects violations.
# scripts/test.sh builds with g++, so both compilers build every change.
#
# Under the sanitizers our Eigen and SIFT-heavy code runs 10-20x slower (measured: the
# end-to-end train-and-localise test 192 s against 10 s), so the whole-pipeline tests are
# left to the plain suite: the real-data evaluation, the end-to-end and frame-size tests,
# the generated tour's SIFT checks, the CLI's train-then-eval and the 2,000-location scale
# slice. Every unit, server and client test runs here. SCENELOC_SANITIZE_ALL=1 runs everything (about 40 minutes).
#
# Portable code (-DSCENELOC_AVX2=OFF, as the Docker image builds): the hot loops have an
# AVX2 path and a plain one (e.g. S_D's bound, common/matching/descriptor_similarity.cc);
# scripts/test.sh tests the first, this suite the second, so CI runs both.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh --clang
# A build-asan configured with g++ (before this script used clang) is configured afresh.
if [[ -f build-asan/CMakeCache.txt ]] &&
  ! grep -q '^CMAKE_CXX_COMPILER:.*clang' build-asan/CMakeCache.txt; then
  echo "sanitize.sh: build-asan was configured with another compiler; configuring it for clang"
  rm -rf build-asan/CMakeCache.txt build-asan/CMakeFiles
fi
if [[ ! -f build-asan/CMakeCache.txt ]]; then
  generator=()
  command -v ninja >/dev/null && generator=(-G Ninja)
  CXX=clang++ cmake -S . -B build-asan "${generator[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DASAN=ON -DUBSAN=ON -DSCENELOC_BUILD_BENCHMARKS=OFF
fi
cmake -S . -B build-asan -DSCENELOC_AVX2=OFF >/dev/null
cmake --build build-asan -j"$(nproc)"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:allocator_may_return_null=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/tests/lsan.supp:print_suppressions=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
cd build-asan
exclude=()
if [[ "${SCENELOC_SANITIZE_ALL:-0}" != 1 ]]; then
  exclude=(-E 'RealDataTest|EndToEndTest|FramesTest|TrainFramesMap|TourGeneratorSiftTest|CliTest.TrainThenEval|ScaleSliceTest')
fi
ctest --output-on-failure -j"$(nproc)" "${exclude[@]}" "$@"
