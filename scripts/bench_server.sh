#!/usr/bin/env bash
# The server's targets on Gardens Point: latency of one client (JPEG and feature-set
# requests), 8-client throughput against a --threads 1 server, the map replaced under
# 8-client load, and resident memory with one and two maps. Prints every figure and keeps
# the sceneloc bench JSON files in OUT_DIR. About 3 minutes on 2 cores.
# Usage: scripts/bench_server.sh [OUT_DIR] [DATA_DIR] [SECONDS_PER_RUN]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="$(mkdir -p "${1:-$root/bench-out}" && cd "${1:-$root/bench-out}" && pwd)"
data="${2:-$root/../shared/data/gardens_point}"
seconds="${3:-15}"
build="$root/build"
client="$build/client/sceneloc"

# shellcheck source=scripts/bench_common.sh
source "$root/scripts/bench_common.sh"
need_gp_data "$data"

# bench NAME CLIENTS [EXTRA...]: one sceneloc bench run over the day_right images.
bench() {
  local name=$1 clients=$2; shift 2
  "$client" bench --server "$endpoint" --map gp --clients "$clients" --duration "$seconds" \
    --json "$out/$name.json" "$@" "$data/day_right" | sed "s/^/[$name] /" ||
    true  # refused requests (OVERLOADED on one thread) are figures, in the JSON, not a failure
}

bash "$root/scripts/build.sh" >/dev/null
train_gp_map "$data"
rm -f "$out/maps/gp2.scnl"

start_server 2 --threads 2
rss_one=$(rss_mb)
echo "resident memory, 1 map: $rss_one MB"
cp "$out/maps/gp.scnl" "$out/maps/gp2.scnl"
deadline=$((SECONDS + 30))
until "$client" maps --server "$endpoint" | grep -q gp2; do
  ((SECONDS < deadline)) || { echo "bench_server: second map never loaded" >&2; exit 1; }
  sleep 0.2
done
rss_two=$(rss_mb)
echo "resident memory, 2 maps: $rss_two MB"
rm -f "$out/maps/gp2.scnl"
bench one_client_jpeg 1
bench one_client_features 1 --features
bench eight_clients 8
# The map replaced (a new generation) a third of the way into an 8-client run.
(sleep "$((seconds / 3))"; cp "$out/maps/gp.scnl" "$out/maps/.gp.new" &&
  mv "$out/maps/.gp.new" "$out/maps/gp.scnl") &
replacer=$!
bench eight_clients_reload 8
wait "$replacer"
stop_server

start_server 1 --threads 1
bench eight_clients_threads1 8
stop_server

/usr/bin/python3 - "$out" "$rss_one" "$rss_two" "$("$client" --version)" <<'PY'
import json, sys
out = sys.argv[1]
version = sys.argv[4]  # the build's --version: the commit these figures were made at
r = {n: json.load(open(f"{out}/{n}.json")) for n in (
    "one_client_jpeg", "one_client_features", "eight_clients", "eight_clients_reload",
    "eight_clients_threads1")}
for n, j in r.items():
    lat = j["latency_ms"]
    print(f"{n:24s} requests {j['requests']:6d}  {j['throughput_rps']:7.1f} req/s  "
          f"p50 {lat['p50']:6.1f}  p90 {lat['p90']:6.1f}  p99 {lat['p99']:6.1f} ms  "
          f"errors {j['errors']}  generations {j['map_versions']}")
print(f"8 clients: --threads 2 / --threads 1 throughput = "
      f"{r['eight_clients']['throughput_rps'] / r['eight_clients_threads1']['throughput_rps']:.2f}x")
print(f"reload under load: p99 {r['eight_clients_reload']['latency_ms']['p99']:.1f} ms "
      f"vs {r['eight_clients']['latency_ms']['p99']:.1f} ms without")
# The figures above in one file, for the results page (scripts/results_page.py record server).
summary = {"version": version,
           "rss_mb": {"one_map": float(sys.argv[2]), "two_maps": float(sys.argv[3])}, "runs": {
    n: {k: j[k] for k in ("requests", "throughput_rps", "errors", "map_versions", "latency_ms")}
    for n, j in r.items()}}
json.dump(summary, open(f"{out}/server.json", "w"), indent=1)
print(f"{out}/server.json")
PY
