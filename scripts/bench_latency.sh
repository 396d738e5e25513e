#!/usr/bin/env bash
# The latency targets in one run on Gardens Point (day_left map, day_right queries):
#   1. latency_floor: every stage beside plain SIFT detectAndCompute on the same frames;
#   2. this checkout's server and a previous commit's (BASE_REV, built in OUT/base-src
#      unless BASE_BUILD names a build folder of it), each with its own map and
#      --threads 2: one client sending JPEGs, one sending feature sets, eight sending JPEGs.
# Prints every figure and the ratios; keeps the sceneloc bench JSON files in OUT_DIR.
# About 8 minutes on 2 cores once both are built. One measurement at a time: run nothing
# else meanwhile.
# Usage: scripts/bench_latency.sh [OUT_DIR] [DATA_DIR] [BASE_REV] [SECONDS_PER_RUN]
#   BASE_BUILD=/path/to/old/build scripts/bench_latency.sh   # reuse a built base
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
top="$(mkdir -p "${1:-$root/bench-out/latency}" && cd "${1:-$root/bench-out/latency}" && pwd)"
data="${2:-$root/../shared/data/gardens_point}"
base_rev="${3:-HEAD~1}"
seconds="${4:-15}"
client="$root/build/client/sceneloc"

# shellcheck source=scripts/bench_common.sh
source "$root/scripts/bench_common.sh"
need_gp_data "$data"
bash "$root/scripts/build.sh" >/dev/null

base_build="${BASE_BUILD:-}"
if [[ -z "$base_build" ]]; then
  src="$top/base-src"
  if [[ ! -d "$src" ]]; then
    git -C "$root" worktree add --detach "$src" "$base_rev" >/dev/null
  fi
  echo "building $base_rev in $src (once)"
  cmake -S "$src" -B "$src/build" -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$src/build" -j"$(nproc)" --target sceneloc-server sceneloc-train >/dev/null
  base_build="$src/build"
fi

# bench NAME CLIENTS [EXTRA...]: one sceneloc bench run over the day_right images.
bench() {
  local name=$1 clients=$2; shift 2
  "$client" bench --server "$endpoint" --map gp --clients "$clients" --duration "$seconds" \
    --json "$out/$name.json" "$@" "$data/day_right" | grep -E '^(throughput|latency|server p50)' |
    sed "s/^/[$label $name] /"
}

# One server (build folder $1, label $2): its own map, then the three runs.
measure() {
  build="$1" label="$2" out="$top/$2"
  mkdir -p "$out"
  train_gp_map "$data" >/dev/null
  start_server 2 --threads 2
  bench one_client_jpeg 1
  bench one_client_features 1 --features
  bench eight_clients 8
  stop_server
}

echo "== stages against the floor (latency_floor, 100 frames)"
"$root/build/tools/sceneloc-train" --tour "$data/day_left" --out "$top/floor.scnl" \
  --config "$root/configs/train.yaml" >/dev/null
"$root/build/bench/latency_floor" --map "$top/floor.scnl" --queries "$data/day_right" \
  --frames 100 --rounds 2 | tee "$top/floor.txt"
floor_ms="$(awk '/^floor:/ {print $(NF-2)}' "$top/floor.txt")"

echo "== servers, --threads 2, $seconds s per run"
measure "$base_build" base
measure "$root/build" current

/usr/bin/python3 - "$top" "$floor_ms" "$("$client" --version)" "$base_rev" <<'PY'
import json, re, sys
top, floor = sys.argv[1], float(sys.argv[2])
runs = ("one_client_jpeg", "one_client_features", "eight_clients")
r = {(s, n): json.load(open(f"{top}/{s}/{n}.json")) for s in ("base", "current") for n in runs}
print(f"{'run':22s} {'base req/s':>10s} {'p50':>7s} {'p99':>7s}   {'now req/s':>9s} {'p50':>7s} "
      f"{'p99':>7s}   throughput x   p50/floor")
for n in runs:
    b, c = r[("base", n)], r[("current", n)]
    print(f"{n:22s} {b['throughput_rps']:10.1f} {b['latency_ms']['p50']:7.1f} "
          f"{b['latency_ms']['p99']:7.1f}   {c['throughput_rps']:9.1f} {c['latency_ms']['p50']:7.1f} "
          f"{c['latency_ms']['p99']:7.1f}   {c['throughput_rps'] / b['throughput_rps']:12.2f}"
          f"   {c['latency_ms']['p50'] / floor:9.2f}")
print(f"floor (detectAndCompute, 1 thread, same frames): {floor:.2f} ms")
# The figures above in one file, for the results page (scripts/results_page.py record latency).
stages = []
for line in open(f"{top}/floor.txt"):
    m = re.match(r"^(.+?)\s+([0-9.]+)\s+([0-9.]+)\s+([0-9.]+)$", line.rstrip())
    if m and not line.startswith("stage"):
        stages.append({"stage": m.group(1).strip(), "p50_ms": float(m.group(2)),
                       "p99_ms": float(m.group(3)), "over_floor": float(m.group(4))})
summary = {"version": sys.argv[3], "base": sys.argv[4], "floor_ms": floor, "stages": stages,
           "runs": {n: {s: {"throughput_rps": r[(s, n)]["throughput_rps"],
                            "latency_ms": r[(s, n)]["latency_ms"]} for s in ("base", "current")}
                    for n in runs}}
json.dump(summary, open(f"{top}/latency.json", "w"), indent=1)
print(f"{top}/latency.json")
PY
