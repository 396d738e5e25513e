#!/usr/bin/env bash
# sceneloc end to end, the way a robot uses it: installs and builds, generates a synthetic
# tour and a laterally shifted test pass, trains a landmark map, starts sceneloc-server on
# a free local port, localises every test frame through the `sceneloc` client, prints the
# answers (location, LOCALISED or UNKNOWN, confidence), the match rate (answer within ±1 of
# the true location) and how many answers were confident enough to act on, sends the same
# frames again as one robot's session (docs/sessions.md) and shows the session's
# answers, and stops the server.
# Usage: scripts/demo.sh [WORK_DIR]   (default: ./demo-out)
set -euo pipefail
started=$SECONDS
root="$(cd "$(dirname "$0")/.." && pwd)"
work="$(mkdir -p "${1:-$root/demo-out}" && cd "${1:-$root/demo-out}" && pwd)"
bash "$root/scripts/setup.sh"
# Only the four programs the demo runs; scripts/test.sh builds the rest (tests, benchmarks).
SCENELOC_BUILD_TARGETS="sceneloc-gentour sceneloc-train sceneloc-server sceneloc" \
  bash "$root/scripts/build.sh"
build="$root/build"
locations=40

server_pid=""
stop_server() {
  if [[ -n "$server_pid" ]] && kill -0 "$server_pid" 2>/dev/null; then
    kill -TERM "$server_pid"
    wait "$server_pid" || true
  fi
}
trap stop_server EXIT
trap 'exit 130' INT TERM

echo "== 1. generating a tour of $locations locations and a test pass in $work"
rm -rf "$work/tour" "$work/test" "$work/maps"
"$build/tools/sceneloc-gentour" --out "$work" --locations "$locations" --width 960 --height 540

echo "== 2. training a map into $work/maps"
mkdir -p "$work/maps"
"$build/tools/sceneloc-train" --tour "$work/tour" --out "$work/maps/demo.scnl" \
  --config "$root/configs/train.yaml"

echo "== 3. starting sceneloc-server on a free port of 127.0.0.1"
log="$work/server.log"
"$build/server/sceneloc-server" --config "$root/configs/server.yaml" --maps "$work/maps" \
  --endpoint 'tcp://127.0.0.1:*' --threads 2 >"$log" 2>&1 &
server_pid=$!
# The server logs the endpoint it bound ("serving N map(s) on tcp://127.0.0.1:PORT ...").
endpoint=""
for _ in $(seq 100); do
  endpoint="$(grep -o 'on tcp://127\.0\.0\.1:[0-9]*' "$log" | head -n1 | cut -c4- || true)"
  [[ -n "$endpoint" ]] && break
  kill -0 "$server_pid" 2>/dev/null || { cat "$log" >&2; echo "demo: the server exited" >&2; exit 1; }
  sleep 0.1
done
[[ -n "$endpoint" ]] || { cat "$log" >&2; echo "demo: the server did not start in 10 s" >&2; exit 1; }
# Ready when it answers a ListMaps request.
deadline=$((SECONDS + 30))
until "$build/client/sceneloc" maps --server "$endpoint" --timeout-ms 500 >/dev/null 2>&1; do
  ((SECONDS < deadline)) || { cat "$log" >&2; echo "demo: no answer from $endpoint" >&2; exit 1; }
  sleep 0.2
done
"$build/client/sceneloc" maps --server "$endpoint"

echo "== 4. localising the $locations test frames through the client"
answers="$work/answers.tsv"
status=0
"$build/client/sceneloc" localise --server "$endpoint" --map demo "$work"/test/*.jpg \
  >"$answers" || status=$?
sed "s|$work/test/||" "$answers"
echo "(answers shown $((SECONDS - started)) s after the demo started, installation and build included)"
# Image007.jpg is location 7; the answer is the second column.
score() {
  awk -F'\t' -v tolerance=1 '
  { n++
    name = $1; sub(/.*\//, "", name); gsub(/[^0-9]/, "", name)
    if ($2 ~ /^[0-9]+$/ && ($2 - name <= tolerance && name - $2 <= tolerance)) hits++ }
  $4 == "LOCALISED" { localised++ }
  END { printf "match rate (within ±%d): %d / %d = %.2f; LOCALISED (confidence >= the server'"'"'s min_confidence): %d / %d\n",
               tolerance, hits, n, n ? hits / n : 0, localised, n }
' "$1"
}
grep -v $'\tsession ' "$answers" >"$answers.single"
score "$answers.single"
((status == 0)) || echo "demo: some requests got an error reply (see above)" >&2

echo "== 5. the same frames as one robot's session: each answer filtered with the frames before it"
"$build/client/sceneloc" localise --server "$endpoint" --map demo --session demo-robot \
  --reset-session "$work"/test/*.jpg >"$answers" || status=$?
grep $'\tsession ' "$answers" | sed "s|$work/test/||" | tail -n 5
grep $'\tsession ' "$answers" | cut -f1,3- >"$answers.session"
score "$answers.session"

echo "== 6. stopping the server"
stop_server
tail -n 2 "$log"
exit "$status"
