#!/usr/bin/env bash
# Configures and builds sceneloc (Release) into ./build. Extra arguments go to CMake's
# configure step, e.g. scripts/build.sh -DASAN=ON. SCENELOC_BUILD_TARGETS="a b" builds only
# those targets and what they need (scripts/demo.sh builds its four programs alone).
set -euo pipefail
cd "$(dirname "$0")/.."
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
if [[ ! -f build/CMakeCache.txt ]]; then
  cmake -S . -B build "${generator[@]}" -DCMAKE_BUILD_TYPE=Release "$@"
elif (($#)); then
  cmake -S . -B build "$@"
fi
targets=()
for t in ${SCENELOC_BUILD_TARGETS:-}; do targets+=(--target "$t"); done
cmake --build build -j"$(nproc)" "${targets[@]}"
