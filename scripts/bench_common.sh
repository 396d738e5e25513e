# Shared by the server benchmark scripts (source it; needs $root, $out, $build, $client).
# start_server NAME ARGS...: starts sceneloc-server on a free port with its log in
# $out/server-NAME.log and the extra ARGS; sets $endpoint and $server_pid. stop_server
# stops it (SIGTERM, waits). rss_mb prints its resident memory.
# shellcheck shell=bash

# configs_of BUILD: the configs/ folder of the source tree BUILD was configured from, so a
# previous commit's server reads the settings files it knows (a newer file may hold keys
# it refuses).
configs_of() {
  local src
  src="$(sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$1/CMakeCache.txt" 2>/dev/null)"
  echo "${src:-$root}/configs"
}

server_pid=""
stop_server() {
  if [[ -n "$server_pid" ]] && kill -0 "$server_pid" 2>/dev/null; then
    kill -TERM "$server_pid"; wait "$server_pid" || true
  fi
  server_pid=""
}
trap stop_server EXIT

# probe_args: extra sceneloc arguments for the readiness probe (e.g. CURVE keys).
probe_args=()
start_server() {
  local name=$1; shift
  local log="$out/server-$name.log"
  "$build/server/sceneloc-server" --config "$(configs_of "$build")/server.yaml" --maps "$out/maps" \
    --endpoint 'tcp://127.0.0.1:*' --log-level info "$@" >"$log" 2>&1 &
  server_pid=$!
  endpoint=""
  local deadline=$((SECONDS + 30))
  until [[ -n "$endpoint" ]] &&
    "$client" maps --server "$endpoint" --timeout-ms 500 "${probe_args[@]}" >/dev/null 2>&1; do
    ((SECONDS < deadline)) || { cat "$log" >&2; echo "${0##*/}: server did not start" >&2; exit 1; }
    endpoint="$(grep -so 'on tcp://127\.0\.0\.1:[0-9]*' "$log" | head -n1 | cut -c4- || true)"
    sleep 0.2
  done
}

rss_mb() { awk '/VmRSS/ {printf "%.1f", $2 / 1024}' "/proc/$server_pid/status"; }

# need_gp_data DATA: exits with a message unless DATA holds day_left and day_right.
need_gp_data() {
  [[ -d "$1/day_left" && -d "$1/day_right" ]] || {
    echo "${0##*/}: $1/day_left and day_right are needed" >&2; exit 1; }
}

# train_gp_map DATA: trains $out/maps/gp.scnl from DATA/day_left unless it is there.
train_gp_map() {
  mkdir -p "$out/maps"
  if [[ ! -f "$out/maps/gp.scnl" ]]; then
    "$build/tools/sceneloc-train" --tour "$1/day_left" --out "$out/maps/gp.scnl" \
      --config "$(configs_of "$build")/train.yaml" | tail -n 4
  fi
}
