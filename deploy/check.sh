#!/usr/bin/env bash
# deploy/check.sh: the fleet of deploy/ in miniature, inside the built image. Makes a map
# (sceneloc-gentour, sceneloc-train), starts sceneloc-broker on loopback and two
# sceneloc-server workers connected to it, waits for both to be ready (/readyz, the probe
# Kubernetes asks), localises test frames through the broker and checks that both workers
# answered (/metrics), kills one worker (SIGKILL) and localises again, then stops the other
# (SIGTERM: drains, exits 0) and the broker. Exit 0 when all of it held, 1 at the first
# failure (with the logs of the processes involved).
#
# The runtime image holds no copy of the source, so the script is passed as an argument:
#   ../shared/tools/container-check -- bash -c "$(cat deploy/check.sh)"      # from the checkout
# It uses only bash and coreutils besides the image's binaries (no curl: HTTP is spoken over
# bash's /dev/tcp). On a development machine, against build/:
#   PATH="$PWD/build/server:$PWD/build/client:$PWD/build/tools:$PATH" SCENELOC_CONFIGS=configs \
#     bash deploy/check.sh
# Ports: the broker's are chosen by the system (tcp://127.0.0.1:*, read back from its log);
# the workers' metrics ports are free ports picked at random (the endpoint has no port 0
# read-back in the log), so nothing here needs a fixed port.
set -euo pipefail

configs=${SCENELOC_CONFIGS:-/etc/sceneloc}
locations=${SCENELOC_CHECK_LOCATIONS:-20}  # tour length: a small map trains in seconds
work=$(mktemp -d "${TMPDIR:-/tmp}/sceneloc-check.XXXXXX")
pids=()

cleanup() {
  for pid in "${pids[@]}"; do
    { kill -KILL "$pid" && wait "$pid"; } 2>/dev/null || true  # wait: no "Killed" notice
  done
  rm -rf "$work"
}
trap cleanup EXIT

step() { printf '\n== %s\n' "$*"; }

# fail MESSAGE [LOG...]: says what failed, shows the end of each log, exits 1.
fail() {
  echo "check: FAILED: $1" >&2
  shift
  for log in "$@"; do
    echo "--- last lines of $(basename "$log")" >&2
    tail -n 20 "$log" >&2 || true
  done
  exit 1
}

# http_get PORT PATH: the whole HTTP/1.0 response (status line, headers, body) from 127.0.0.1.
http_get() (
  exec 3<>"/dev/tcp/127.0.0.1/$1"
  printf 'GET %s HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n' "$2" >&3
  timeout 5 cat <&3
)

# A TCP port on 127.0.0.1 that nothing listens on now.
free_port() {
  local port
  for _ in {1..50}; do
    port=$((20000 + RANDOM % 30000))
    if ! (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null; then
      echo "$port"
      return 0
    fi
  done
  return 1
}

# wait_for SECONDS PID LOG COMMAND...: until COMMAND succeeds; fails if PID exits first or
# SECONDS pass.
wait_for() {
  local deadline=$((SECONDS + $1)) pid=$2 log=$3
  shift 3
  until "$@" >/dev/null 2>&1; do
    kill -0 "$pid" 2>/dev/null || fail "process $pid exited while waiting for: $*" "$log"
    ((SECONDS < deadline)) || fail "not within the time allowed: $*" "$log"
    sleep 0.2
  done
}

# ready PORT: /readyz answers 200. (The response is read whole: a `head` that stopped
# reading early could cut `cat` off with SIGPIPE, which pipefail would count as a failure.)
ready() {
  local response
  response=$(http_get "$1" /readyz) && [[ $response == "HTTP/1."?" 200 "* ]]
}

# localise_ok_count PORT: the worker's count of OK localise answers for map demo.
localise_ok_count() {
  http_get "$1" /metrics |
    sed -n 's/^sceneloc_requests_total{kind="localise",map="demo",status="OK"} \([0-9]*\).*/\1/p'
}

for tool in sceneloc-gentour sceneloc-train sceneloc-broker sceneloc-server sceneloc; do
  command -v "$tool" >/dev/null || fail "$tool is not on PATH"
done
step "binaries in $(dirname "$(command -v sceneloc-server)"), settings in $configs"
[[ -r $configs/train.yaml && -r $configs/server.yaml ]] || fail "no train.yaml, server.yaml in $configs"

step "a tour of $locations locations and its map"
sceneloc-gentour --out "$work/tour" --locations "$locations" || fail "sceneloc-gentour"
mkdir "$work/maps"
sceneloc-train --tour "$work/tour/tour" --out "$work/maps/demo.scnl" \
  --config "$configs/train.yaml" 2>"$work/train.log" || fail "sceneloc-train" "$work/train.log"

step "broker on loopback"
sceneloc-broker --frontend 'tcp://127.0.0.1:*' --backend 'tcp://127.0.0.1:*' >"$work/broker.log" 2>&1 &
broker=$!
pids+=("$broker")
wait_for 10 "$broker" "$work/broker.log" grep -q 'broker: clients on' "$work/broker.log"
frontend=$(sed -n 's/.*broker: clients on \(tcp:[^,]*\), workers on .*/\1/p' "$work/broker.log")
backend=$(sed -n 's/.*, workers on \(tcp:[^ ]*\).*/\1/p' "$work/broker.log")
echo "clients on $frontend, workers on $backend"

step "two workers (--connect $backend --threads 1)"
workers=() ports=()
for i in 1 2; do
  port=$(free_port) || fail "no free port for worker $i's metrics"
  sceneloc-server --config "$configs/server.yaml" --maps "$work/maps" --connect "$backend" \
    --threads 1 --metrics-endpoint "127.0.0.1:$port" >"$work/worker$i.log" 2>&1 &
  workers+=($!)
  pids+=($!)
  ports+=("$port")
done
for i in 0 1; do
  wait_for 60 "${workers[i]}" "$work/worker$((i + 1)).log" ready "${ports[i]}"
  echo "worker $((i + 1)) (pid ${workers[i]}, metrics 127.0.0.1:${ports[i]}): $(http_get "${ports[i]}" /readyz | tail -n 1)"
done

step "localise through the broker"
test_frames=("$work"/tour/test/*.jpg)
frames=("${test_frames[@]:$((${#test_frames[@]} / 2)):4}")  # four from the middle of the pass
sceneloc localise --server "$frontend" --map demo --timeout-ms 2000 "${frames[@]}" ||
  fail "localise through the broker" "$work/broker.log" "$work/worker1.log" "$work/worker2.log"
for i in 0 1; do
  answered=$(localise_ok_count "${ports[i]}") || fail "GET /metrics of worker $((i + 1))"
  echo "worker $((i + 1)) answered ${answered:-0}"
  ((${answered:-0} > 0)) || fail "worker $((i + 1)) answered none: the broker did not share the work" \
    "$work/worker$((i + 1)).log"
done

step "kill worker 1 (SIGKILL), localise again"
kill -KILL "${workers[0]}"
wait "${workers[0]}" 2>/dev/null || true
sceneloc localise --server "$frontend" --map demo --timeout-ms 2000 "${frames[@]:0:3}" ||
  fail "localise with one worker left" "$work/broker.log" "$work/worker2.log"

step "stop worker 2 (SIGTERM: drains, exits 0) and the broker"
kill -TERM "${workers[1]}"
wait "${workers[1]}" || fail "worker 2 exited with status $? on SIGTERM" "$work/worker2.log"
kill -TERM "$broker"
wait "$broker" || fail "the broker exited with status $? on SIGTERM" "$work/broker.log"
pids=()

step "check: OK"
