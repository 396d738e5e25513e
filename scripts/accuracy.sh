#!/usr/bin/env bash
# The accuracy suite in one command: every development set in ../shared/data (Gardens Point
# day, night on both sides of the path, the corridor, and generated variants of the day
# queries: a smaller camera, dusk, heavy JPEG, blur, ...; and a generated street of look-alike
# places, rendered into OUT/cache), each localised by our defaults, by the
# paper as printed, by the FLANN voting baseline and by that baseline re-ranked by RANSAC
# inliers, all on the same features in one run. About 10-15 minutes on 2 cores the first
# time (features are cached in OUT/cache for later runs).
#
# Writes OUT/accuracy.json, OUT/accuracy.csv and OUT/accuracy.png; prints one table.
# Usage: scripts/accuracy.sh [OUT_DIR] [DATA_DIR] [-- more sceneloc-accuracy flags]
#   scripts/accuracy.sh accuracy-out ../shared/data -- --ablation   # the ablation instead
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="${1:-$root/accuracy-out}"
data="${2:-$root/../shared/data}"
shift $(( $# > 2 ? 2 : $# ))
[[ "${1:-}" == "--" ]] && shift
[[ -d "$data/gardens_point" || -d "$data/corridor" ]] || {
  echo "accuracy: no data set under $data (gardens_point/, corridor/)" >&2; exit 1; }
bash "$root/scripts/setup.sh" --plots
bash "$root/scripts/build.sh"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
data="$(cd "$data" && pwd)"
cd "$root"
build/tools/sceneloc-accuracy --data "$data" --out "$out" "$@"
if [[ -f "$out/accuracy.json" && " $* " != *" --ablation "* ]]; then
  /usr/bin/python3 "$root/scripts/plot_accuracy.py" "$out"
fi
