#!/usr/bin/env bash
# sceneloc's main job on a built-in default: generates a synthetic tour and a laterally
# shifted test pass, trains a landmark map, localises every test frame against it and
# prints the answers and the match rate, beside the baseline.
# Usage: scripts/demo.sh [WORK_DIR]   (default: ./demo-out)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
work="${1:-$root/demo-out}"
bash "$root/scripts/setup.sh"
bash "$root/scripts/build.sh"
bin="$root/build/tools"
mkdir -p "$work"
echo "== 1. generating a tour of 40 locations and a test pass in $work"
"$bin/sceneloc-gentour" --out "$work" --locations 40 --width 960 --height 540
echo "== 2. training a map"
"$bin/sceneloc-train" --tour "$work/tour" --out "$work/demo.scnl" --config "$root/configs/train.yaml"
echo "== 3. localising the test pass"
"$bin/sceneloc-eval" --map "$work/demo.scnl" --queries "$work/test" --config "$root/configs/match.yaml" \
  --baseline --show --json "$work/eval.json"
