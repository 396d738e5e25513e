#!/usr/bin/env bash
# What sessions cost in a running server (docs/sessions.md): 1,000 live
# sessions on the 200-location Gardens Point map, each opened by one feature-set frame, then
# the server's own count of them and the memory they hold (stats), beside its resident
# memory before and after; and one client's latency with and without a session, in
# alternating runs (p50, p99, ratio). About 2 minutes.
# Usage: scripts/bench_sessions.sh [OUT_DIR] [DATA_DIR] [SESSIONS] [SECONDS_PER_RUN]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="$(mkdir -p "${1:-$root/bench-out}" && cd "${1:-$root/bench-out}" && pwd)"
data="${2:-$root/../shared/data/gardens_point}"
sessions="${3:-1000}"
seconds="${4:-10}"
build="$root/build"
client="$build/client/sceneloc"
# shellcheck source=scripts/bench_common.sh
source "$root/scripts/bench_common.sh"
need_gp_data "$data"

bash "$root/scripts/build.sh" >/dev/null
train_gp_map "$data"
frame="$out/session-frame.feat"
"$client" extract "$data/day_right/Image042.jpg" --map-file "$out/maps/gp.scnl" --out "$frame" \
  >/dev/null
start_server sessions --threads 2
stat() { "$client" stats --server "$endpoint" | awk -v k="$1:" '$1 == k {print $2}'; }
rss_before="$(rss_mb)"
echo "sessions: opening $sessions sessions (one frame each) on map gp"
for ((s = 0; s < sessions; ++s)); do
  "$client" localise --server "$endpoint" --map gp --features --session "robot-$s" "$frame" \
    >/dev/null
done
live="$(stat sessions)"
bytes="$(stat session_memory_bytes)"
rss_after="$(rss_mb)"
awk -v n="$live" -v b="$bytes" -v r0="$rss_before" -v r1="$rss_after" 'BEGIN {
  printf "live sessions %d, held by them %.2f MB (%.0f bytes each); server RSS %.1f -> %.1f MB\n",
    n, b / 1e6, b / n, r0, r1 }'

bench() {  # bench NAME [--sessions]: one client, feature sets, $seconds s
  "$client" bench --server "$endpoint" --map gp --clients 1 --duration "$seconds" --features \
    --map-file "$out/maps/gp.scnl" --json "$out/sessions-$1.json" "${@:2}" \
    "$data/day_right" >/dev/null
}
for round in 1 2; do bench "plain-$round"; bench "session-$round" --sessions; done
/usr/bin/python3 - "$out" "$live" "$bytes" "$rss_before" "$rss_after" "$("$client" --version)" <<'PY'
import json, sys, statistics as st
out = sys.argv[1]
summary = {"version": sys.argv[6], "sessions": int(sys.argv[2]),
           "session_bytes": int(sys.argv[3]),
           "rss_mb": {"before": float(sys.argv[4]), "after": float(sys.argv[5])},
           "latency_ms": {}}
def p(kind, q):
    return st.median(json.load(open(f"{out}/sessions-{kind}-{r}.json"))["latency_ms"][q] for r in (1, 2))
for q in ("p50", "p99"):
    a, b = p("plain", q), p("session", q)
    print(f"one client, feature sets, {q}: without a session {a:.2f} ms, with one {b:.2f} ms, "
          f"ratio {b / a:.3f}")
    summary["latency_ms"][q] = {"plain": a, "session": b}
# The figures above in one file, for the results page (scripts/results_page.py record sessions).
json.dump(summary, open(f"{out}/sessions.json", "w"), indent=1)
print(f"{out}/sessions.json")
PY
