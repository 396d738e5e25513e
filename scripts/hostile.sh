#!/usr/bin/env bash
# Hostile requests against a real sceneloc-server (bench/hostile_server.cc) with the
# 200-location Gardens Point map, while a well-behaved client localises a frame every half
# second: prints, per attack, what the hostile requests got, the good client's worst
# latency, the server's peak resident memory and whether it stayed up. About 2 minutes.
# Usage: scripts/hostile.sh [OUT_DIR] [DATA_DIR] [THREADS]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="$(mkdir -p "${1:-$root/bench-out}" && cd "${1:-$root/bench-out}" && pwd)"
data="${2:-$root/../shared/data/gardens_point}"
threads="${3:-2}"
build="$root/build"
client="$build/client/sceneloc"
# shellcheck source=scripts/bench_common.sh
source "$root/scripts/bench_common.sh"
need_gp_data "$data"
bash "$root/scripts/build.sh" >/dev/null
train_gp_map "$data"
query="$(ls "$data/day_right" | head -n 1)"
status=0
"$build/bench/hostile_server" --server-bin "$build/server/sceneloc-server" \
  --map "$out/maps/gp.scnl" --query "$data/day_right/$query" --threads "$threads" --large-floods |
  tee "$out/hostile.txt" || status=$?
# The table above in one file, for the results page (scripts/results_page.py record hostile).
/usr/bin/python3 - "$out" "$("$client" --version)" <<'PY'
import json, re, sys
out = sys.argv[1]
text = open(f"{out}/hostile.txt").read()
head = re.search(r"idle RSS (\d+) MB, target peak (\d+) MB; good client at rest: p50 ([0-9.]+) ms",
                 text)
attacks = []
for line in text.splitlines():
    cells = [c.strip() for c in line.split(" | ")]
    if len(cells) == 5 and cells[2].endswith(" ms") and cells[3].endswith(" MB"):
        attacks.append({"attack": cells[0], "hostile_got": cells[1],
                        "good_worst_ms": float(cells[2][:-3]), "peak_rss_mb": float(cells[3][:-3]),
                        "server": cells[4]})
json.dump({"version": sys.argv[2], "idle_rss_mb": float(head.group(1)),
           "target_peak_mb": float(head.group(2)), "good_p50_at_rest_ms": float(head.group(3)),
           "attacks": attacks,
           "all_within_targets": "ALL WITHIN TARGETS" in text},
          open(f"{out}/hostile.json", "w"), indent=1)
print(f"{out}/hostile.json")
PY
exit "$status"
