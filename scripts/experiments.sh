#!/usr/bin/env bash
# The paper's experiments on Gardens Point, with the baseline on the same axes:
#   eta sweep (Fig. 5) and eta_opt against environment size (Fig. 6). The ablation runs on
#   every data set: scripts/accuracy.sh OUT DATA -- --ablation.
# Writes CSVs, PNG plots and OUT_DIR/experiments.json (both tables with the build's version,
# for the results page: scripts/results_page.py record experiments OUT_DIR/experiments.json).
# Long: about 30-60 minutes on 2 cores; not part of the test suite.
# Usage: scripts/experiments.sh OUT_DIR [DATA_DIR]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="${1:?usage: scripts/experiments.sh OUT_DIR [DATA_DIR]}"
data="${2:-$root/../shared/data/gardens_point}"
[[ -d "$data/day_left" && -d "$data/day_right" ]] || {
  echo "experiments: $data/day_left and day_right are needed" >&2; exit 1; }
bash "$root/scripts/setup.sh" --plots
bash "$root/scripts/build.sh"
bin="$root/build/tools/sceneloc-experiments"
common=(--tour "$data/day_left" --queries "$data/day_right" --out "$out" --cache "$out/cache"
        --train-config "$root/configs/train.yaml" --match-config "$root/configs/match.yaml")
"$bin" "${common[@]}" --experiment eta --etas 10,20,30,50,75,100,150,0
"$bin" "${common[@]}" --experiment size --sizes 25,50,100,150,200 --etas 10,20,50,100,0
rm -rf "$out/cache"
/usr/bin/python3 "$root/scripts/plot_experiments.py" "$out"  # Debian's python3-matplotlib
/usr/bin/python3 - "$out" "$("$bin" --version)" <<'PY'
import csv, json, sys
out, version = sys.argv[1], sys.argv[2]
def rows(name):
    with open(f"{out}/{name}.csv", newline="") as f:
        return [{k: (v if k in ("experiment", "variant") else float(v)) for k, v in r.items()}
                for r in csv.DictReader(f)]
json.dump({"version": version, "eta": rows("eta"), "size": rows("size")},
          open(f"{out}/experiments.json", "w"), indent=1)
print(f"{out}/experiments.json")
PY
