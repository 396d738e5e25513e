#!/usr/bin/env bash
# What CURVE costs (docs/security.md): one client's latency with feature-set
# and JPEG requests, and 8 clients' throughput, against the 200-location Gardens Point map,
# with auth off and on, in alternating rounds in one run (so drift hits both alike). Prints
# p50 and p99 of each and the ratio on/off. About 2 x ROUNDS x 3 x SECONDS seconds.
# Usage: scripts/bench_auth.sh [OUT_DIR] [DATA_DIR] [SECONDS_PER_RUN] [ROUNDS]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="$(mkdir -p "${1:-$root/bench-out}" && cd "${1:-$root/bench-out}" && pwd)"
data="${2:-$root/../shared/data/gardens_point}"
seconds="${3:-10}"
rounds="${4:-2}"
build="$root/build"
client="$build/client/sceneloc"
# shellcheck source=scripts/bench_common.sh
source "$root/scripts/bench_common.sh"
need_gp_data "$data"

bash "$root/scripts/build.sh" >/dev/null
train_gp_map "$data"
keys="$out/keys"
rm -rf "$keys"
for name in server robot; do "$client" keygen "$name" --dir "$keys" >/dev/null; done
printf 'clients:\n  - name: robot\n    public_key: "%s"\n' \
  "$(sed -n 's/^public_key: "\(.*\)"$/\1/p' "$keys/robot.pub")" >"$keys/clients.yaml"
curve_args=(--key "$keys/robot.key" --server-key "$keys/server.pub")

for ((round = 1; round <= rounds; round++)); do
  for mode in off on; do
    if [[ $mode == on ]]; then
      probe_args=("${curve_args[@]}")
      start_server "auth-$mode" --threads 2 --auth true --server-key "$keys/server.key" \
        --auth-clients "$keys/clients.yaml"
    else
      probe_args=()
      start_server "auth-$mode" --threads 2
    fi
    for run in features jpeg eight; do
      args=(--clients 1)
      [[ $run == features ]] && args+=(--features --map-file "$out/maps/gp.scnl")
      [[ $run == eight ]] && args=(--clients 8 --features --map-file "$out/maps/gp.scnl")
      "$client" bench --server "$endpoint" --map gp --duration "$seconds" "${args[@]}" \
        "${probe_args[@]}" --json "$out/auth-$mode-$run-$round.json" "$data/day_right" >/dev/null
    done
    stop_server
  done
done

/usr/bin/python3 - "$out" "$rounds" "$("$client" --version)" <<'PY'
import json, statistics, sys
out, rounds = sys.argv[1], int(sys.argv[2])
summary = {"version": sys.argv[3], "rounds": rounds, "runs": {}}
for run in ("features", "jpeg", "eight"):
    row = {}
    for mode in ("off", "on"):
        js = [json.load(open(f"{out}/auth-{mode}-{run}-{r}.json")) for r in range(1, rounds + 1)]
        row[mode] = (statistics.median(j["latency_ms"]["p50"] for j in js),
                     statistics.median(j["latency_ms"]["p99"] for j in js),
                     statistics.median(j["throughput_rps"] for j in js),
                     sum(j["requests"] - j["ok"] for j in js))
    label = {"features": "1 client, feature sets", "jpeg": "1 client, JPEG",
             "eight": "8 clients, feature sets"}[run]
    off, on = row["off"], row["on"]
    print(f"{label:24s} off: p50 {off[0]:6.1f} p99 {off[1]:6.1f} ms {off[2]:6.1f} req/s | "
          f"CURVE: p50 {on[0]:6.1f} p99 {on[1]:6.1f} ms {on[2]:6.1f} req/s | "
          f"p50 x{on[0] / off[0]:.3f}  p99 x{on[1] / off[1]:.3f}  throughput x{on[2] / off[2]:.3f}"
          f"  errors {off[3]}/{on[3]}")
    summary["runs"][label] = {mode: {"p50_ms": v[0], "p99_ms": v[1], "throughput_rps": v[2],
                                     "errors": v[3]} for mode, v in row.items()}
# The figures above in one file, for the results page (scripts/results_page.py record auth).
json.dump(summary, open(f"{out}/auth.json", "w"), indent=1)
print(f"{out}/auth.json")
PY
