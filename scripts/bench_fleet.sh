#!/usr/bin/env bash
# The fleet's figures (docs/operations.md "A fleet"), on loopback in one run, against the
# 200-location Gardens Point map, in alternating rounds so that drift hits every setup
# alike:
#   direct     one sceneloc-server --threads 1 bound directly
#   broker1    sceneloc-broker with one worker --threads 1 behind it
#   broker2    the broker with two workers --threads 1
#   direct2    one sceneloc-server --threads 2 (the same two cores in one process)
# Runs per setup: 8 clients of feature sets and of JPEGs (throughput), each setup alone.
# Then `direct` and `broker1` side by side for one client's latency (feature sets over the
# day_right folder, over one frame, the same as uint8), runs alternating, and against
# `direct` the Python client's round trip on that one frame (bench_roundtrip.py). Then one
# run with a worker killed (SIGKILL) mid-run: 8 clients with --retries 3 --timeout-ms 1000.
# Every server runs with --max-queue-wait-ms 10000: this measures capacity, so 8 clients
# queue on one thread rather than being refused (limits.max_queue_wait_ms is 500 by
# default). Throughput counts answered (OK) requests. Prints the ratios the issue asks for;
# JSON of every run is left in OUT_DIR.
# About ROUNDS x (14 x SECONDS + 20) + 2 x SECONDS + 20 seconds (defaults 10 s, 5 rounds:
# 15 min).
# Usage: scripts/bench_fleet.sh [OUT_DIR] [DATA_DIR] [SECONDS_PER_RUN] [ROUNDS]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="$(mkdir -p "${1:-$root/bench-out}" && cd "${1:-$root/bench-out}" && pwd)"
data="${2:-$root/../shared/data/gardens_point}"
seconds="${3:-10}"
rounds="${4:-5}"  # medians of 5: of 2 a median is their mean, and one slow round moves it
build="$root/build"
client="$build/client/sceneloc"
# shellcheck source=scripts/bench_common.sh
source "$root/scripts/bench_common.sh"
need_gp_data "$data"

bash "$root/scripts/build.sh" >/dev/null
train_gp_map "$data"
map_file="$out/maps/gp.scnl"

# One frame, as a folder (for sceneloc bench) and as a feature-set file (for Python).
frame="$(find "$data/day_right" -name '*.jpg' | sort | head -n 1)"
mkdir -p "$out/one"
cp "$frame" "$out/one/"
"$client" extract "$frame" --out "$out/one.pb" --map-file "$map_file" --float32 >/dev/null

# The Python client of this checkout, installed offline into a venv of Debian's python.
py="$out/pyvenv/bin/python"
[[ -x $py ]] || /usr/bin/python3 -m venv --system-site-packages "$out/pyvenv"
rm -rf "$out/pystage" && mkdir -p "$out/pystage/client" "$out/pystage/proto"
cp -R "$root/client/python" "$out/pystage/client/"
cp "$root/proto/sceneloc.proto" "$out/pystage/proto/"
"$py" -m pip install --quiet --no-index --no-build-isolation --no-deps --force-reinstall \
  "$out/pystage/client/python"

# --- processes: a broker and workers, besides start_server/stop_server for direct runs
pids=()
cleanup() {
  stop_server
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  pids=()
}
trap cleanup EXIT

start_broker() {
  rm -f "$out/broker.log"
  "$build/server/sceneloc-broker" --frontend 'tcp://127.0.0.1:*' --backend 'tcp://127.0.0.1:*' \
    >"$out/broker.log" 2>&1 &
  pids+=($!)
  local deadline=$((SECONDS + 10))
  until grep -q "workers on" "$out/broker.log"; do
    ((SECONDS < deadline)) || { cat "$out/broker.log" >&2; exit 1; }
    sleep 0.1
  done
  endpoint="$(grep -o 'clients on tcp://[0-9.:]*' "$out/broker.log" | cut -d' ' -f3)"
  backend="$(grep -o 'workers on tcp://[0-9.:]*' "$out/broker.log" | cut -d' ' -f3)"
}

# start_worker NAME: a worker --threads 1 connected to $backend; waits until it says so.
start_worker() {
  local log="$out/worker-$1.log"
  rm -f "$log"  # so that the wait below reads this worker's log, not an earlier one's
  "$build/server/sceneloc-server" --config "$root/configs/server.yaml" --maps "$out/maps" \
    --connect "$backend" --threads 1 --max-queue-wait-ms 10000 --log-level info >"$log" 2>&1 &
  pids+=($!)
  worker_pid=$!
  local deadline=$((SECONDS + 30))
  until grep -q "connected to the broker" "$log"; do
    ((SECONDS < deadline)) || { cat "$log" >&2; exit 1; }
    sleep 0.1
  done
}

# bench NAME RUN ARGS...: one sceneloc bench run against $endpoint into NAME-RUN-ROUND.json.
bench() {
  local name=$1 run=$2; shift 2
  "$client" bench --server "$endpoint" --map gp --duration "$seconds" "$@" \
    --json "$out/fleet-$name-$run-$round.json" >/dev/null || true  # errors: in the table
}

throughput_runs() {
  bench "$1" f8 --clients 8 --features --map-file "$map_file" "$data/day_right"
  bench "$1" j8 --clients 8 "$data/day_right"
}

# latency_run RUN: one client's RUN against the direct server and through the broker, one
# after the other.
latency_run() {
  local run=$1 args=(--clients 1 --features --map-file "$map_file")
  case $run in
    f1) args+=(--float32 "$data/day_right") ;;
    f1u8) args+=(--uint8 "$data/day_right") ;;
    one) args+=(--float32 "$out/one") ;;
    one8) args+=(--uint8 "$out/one") ;;
  esac
  endpoint=$direct_endpoint bench direct "$run" "${args[@]}"
  endpoint=$broker_endpoint bench broker1 "$run" "${args[@]}"
}

for ((round = 1; round <= rounds; round++)); do
  # Throughput: each setup alone on the cores.
  start_server direct --threads 1 --max-queue-wait-ms 10000
  throughput_runs direct
  stop_server
  start_broker
  start_worker a
  throughput_runs broker1
  start_worker b
  throughput_runs broker2
  cleanup
  start_server direct2 --threads 2 --max-queue-wait-ms 10000
  throughput_runs direct2
  stop_server

  # One client's latency: the direct server and a broker with one worker run side by side
  # and the runs alternate, so both paths see the same machine (run apart, the same path's
  # figure moved by 0.5 ms with what else was running).
  start_server direct --threads 1 --max-queue-wait-ms 10000
  direct_endpoint=$endpoint
  start_broker
  start_worker a
  broker_endpoint=$endpoint
  for run in f1 f1u8 one one8; do latency_run "$run"; done
  "$py" "$root/client/python/bench_roundtrip.py" --server "$direct_endpoint" --map gp \
    --features "$out/one.pb" -n 300 >"$out/fleet-python-$round.txt"
  cleanup
done

# A worker killed mid-run: the client's retry must save every request.
round=kill
start_broker
start_worker a
start_worker b
"$client" bench --server "$endpoint" --map gp --duration $((2 * seconds)) --clients 8 --features \
  --map-file "$map_file" --retries 3 --timeout-ms 1000 \
  --json "$out/fleet-kill.json" "$data/day_right" >"$out/fleet-kill.txt" 2>&1 &
bench_pid=$!
# The bench extracts its feature sets first (seconds); kill halfway through the sending.
until grep -q "sending for" "$out/fleet-kill.txt"; do sleep 0.1; done
sleep "$seconds"
kill -KILL "$worker_pid"
wait "$bench_pid" || true
cleanup

/usr/bin/python3 - "$out" "$rounds" "$("$client" --version)" <<'PY'
import json, re, statistics, sys
out, rounds = sys.argv[1], int(sys.argv[2])
summary = {"version": sys.argv[3], "rounds": rounds, "throughput_rps": {}, "one_client": {}}
def runs(name, run):
    return [json.load(open(f"{out}/fleet-{name}-{run}-{r}.json")) for r in range(1, rounds + 1)]
def med(name, run, key):
    js = runs(name, run)
    if key == "rps":
        return statistics.median(j["ok"] / j["elapsed_s"] for j in js)
    if key == "outside":  # each request's latency less its server time: network, broker, client
        return statistics.median(j["outside_ms"]["p50"] for j in js)
    return statistics.median(j["latency_ms"][key] for j in js)
def errors(name, run):
    return sum(j["requests"] - j["ok"] for j in runs(name, run))
print(f"medians of {rounds} rounds; every process on this machine's cores")
print(f"{'run':<28}{'direct':>14}{'broker+1':>14}{'broker+2':>14}{'direct --threads 2':>20}")
for run, label in (("f8", "8 clients, feature sets"), ("j8", "8 clients, JPEG")):
    cells = [f"{med(n, run, 'rps'):.1f} req/s" for n in ("direct", "broker1", "broker2", "direct2")]
    print(f"{label:<28}" + "".join(f"{c:>14}" for c in cells[:3]) + f"{cells[3]:>20}")
    print(f"{'':<28}two workers / one: {med('broker2', run, 'rps') / med('broker1', run, 'rps'):.2f}x"
          f"; errors {sum(errors(n, run) for n in ('direct', 'broker1', 'broker2', 'direct2'))}")
    summary["throughput_rps"][label] = {
        n: med(n, run, "rps") for n in ("direct", "broker1", "broker2", "direct2")}
    summary["throughput_rps"][label]["errors"] = sum(
        errors(n, run) for n in ("direct", "broker1", "broker2", "direct2"))
print("1 client: p50 direct / through the broker; outside the server (the median over requests of "
      "each one's latency less its server time: network, broker, client) and what the broker adds")
for run, label in (("f1", "features, 100 frames"), ("f1u8", "features uint8, 100 frames"),
                   ("one", "features, 1 frame"),
                   ("one8", "features uint8, 1 frame")):
    d50, b50 = med("direct", run, "p50"), med("broker1", run, "p50")
    do, bo = med("direct", run, "outside"), med("broker1", run, "outside")
    summary["one_client"][label] = {"direct_p50": d50, "broker_p50": b50, "direct_outside": do,
                                    "broker_outside": bo, "direct_p99": med("direct", run, "p99"),
                                    "broker_p99": med("broker1", run, "p99")}
    print(f"  {label:<26} p50 {d50:.2f} / {b50:.2f} ms; outside {do:.2f} / {bo:.2f} ms: "
          f"broker {bo - do:+.2f} ms; p99 {med('direct', run, 'p99'):.2f} / "
          f"{med('broker1', run, 'p99'):.2f} ms")
py = []
for r in range(1, rounds + 1):
    text = open(f"{out}/fleet-python-{r}.txt").read()
    trip = re.search(r"round trip ms\s+median ([0-9.]+)\s+p99 ([0-9.]+)", text).groups()
    outside = re.search(r"outside ms\s+median ([0-9.]+)", text).group(1)
    py.append((float(trip[0]), float(trip[1]), float(outside)))
cpp50, cpp99 = med("direct", "one", "p50"), med("direct", "one", "p99")
py50, py99 = statistics.median(p[0] for p in py), statistics.median(p[1] for p in py)
py_out, cpp_out = statistics.median(p[2] for p in py), med("direct", "one", "outside")
print(f"Python vs C++ client, 1 frame, direct: p50 {py50:.2f} vs {cpp50:.2f} ms "
      f"({py50 - cpp50:+.2f} ms); outside the server {py_out:.2f} vs {cpp_out:.2f} ms "
      f"({py_out - cpp_out:+.2f} ms); p99 {py99:.2f} vs {cpp99:.2f} ms")
k = json.load(open(f"{out}/fleet-kill.json"))
print(f"{'a worker killed mid-run':<28} {k['requests']} requests, {k['requests'] - k['ok']} failed "
      f"({k['errors']}), {k.get('retries', 0)} attempts retried")
summary["python_one_frame"] = {"python_p50": py50, "cpp_p50": cpp50, "python_p99": py99,
                               "cpp_p99": cpp99, "python_outside": py_out, "cpp_outside": cpp_out}
summary["worker_killed"] = {"requests": k["requests"], "failed": k["requests"] - k["ok"],
                            "retried": k.get("retries", 0)}
# The figures above in one file, for the results page (scripts/results_page.py record fleet).
json.dump(summary, open(f"{out}/fleet.json", "w"), indent=1)
print(f"{out}/fleet.json")
PY
