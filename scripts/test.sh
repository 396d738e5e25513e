#!/usr/bin/env bash
# Sets up, builds and runs every test (unit, integration, end to end). The real-data test
# runs when ../shared/data/gardens_point is beside the checkout and is skipped otherwise.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh
cd build
ctest --output-on-failure -j"$(nproc)" "$@"
