#!/usr/bin/env bash
# Issue 8's attacks on a real sceneloc-server (bench/hostile_server.cc) with the
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
"$build/bench/hostile_server" --server-bin "$build/server/sceneloc-server" \
  --map "$out/maps/gp.scnl" --query "$data/day_right/$query" --threads "$threads"
