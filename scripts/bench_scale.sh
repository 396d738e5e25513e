#!/usr/bin/env bash
# Maps that grow: how training, memory, loading, requests and accuracy grow with the map.
# For each size it builds a tour (Gardens Point day_left, 200 real locations; beyond 200 the
# corridor's 111 reference frames as look-alike places of another building, then generated
# distractor locations of `sceneloc-gentour --width 960 --height 540 --seed 11`), trains it,
# serves it and measures:
#   training time (all, and all but feature extraction, per location), peak RSS, map file,
#   the server's memory with the map, its load time, its peak memory while a new generation
#   of the map is loaded beside it, one client's request p50/p99 (JPEG and feature set), and
#   on the real queries (GP day_right 000-099) +-2, LOCALISED precision, the same queries in
#   route order as one robot's session (the sequence filter's cost per frame, +-2) and the
#   LOCALISED share of frames from off the route (generated frames of another seed, never in
#   a map).
# Prints one table with each figure's slope against the map's size (log-log, between the
# two largest sizes) and its projection to 100,000 locations, and writes OUT/scale.json,
# OUT/scale.md and OUT/scale.png. A benchmark, not a test: about 75 minutes on 2 cores for
# the default sizes, of which 15 rendering the distractors once (kept in OUT for later runs).
# Usage: scripts/bench_scale.sh [OUT_DIR] [DATA_DIR] [SIZES] [SECONDS_PER_BENCH]
#   SIZES: locations, e.g. "200 2000 20000" (the default); each at least 200.
#   SCENELOC_SCALE_KEEP_MAPS=1 keeps the maps (and training figures) an earlier run left in
#   OUT and measures the rest afresh: the serving figures of every size in one quiet run.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="$(mkdir -p "${1:-$root/scale-out}" && cd "${1:-$root/scale-out}" && pwd)"
data="$(cd "${2:-$root/../shared/data}" && pwd)"
read -r -a sizes <<<"${3:-200 2000 20000}"
seconds="${4:-20}"
keep_maps="${SCENELOC_SCALE_KEEP_MAPS:-0}"
build="$root/build"
client="$build/client/sceneloc"
threads=2

# shellcheck source=scripts/bench_common.sh
source "$root/scripts/bench_common.sh"
need_gp_data "$data/gardens_point"
bash "$root/scripts/build.sh" >/dev/null

largest=0
for n in "${sizes[@]}"; do
  ((n >= 200)) || { echo "bench_scale: sizes start at 200 (the real tour)" >&2; exit 2; }
  ((n > largest)) && largest=$n
done
corridor=()
[[ -d "$data/corridor/ref" ]] && mapfile -t corridor < <(ls "$data/corridor/ref"/*.jpg | sort -V)

# The distractors, rendered once for the largest size; and the off-route frames.
wanted=$((largest - 200 - ${#corridor[@]}))
have=$( (ls "$out/distractors/tour" 2>/dev/null || true) | wc -l)  # none on a first run
if ((wanted > 0 && have < wanted)); then
  echo "rendering $wanted distractor locations"
  "$build/tools/sceneloc-gentour" --out "$out/distractors" --locations "$wanted" --width 960 \
    --height 540 --seed 11 --passes tour --threads "$threads" | tail -n 1
fi
if [[ ! -d "$out/offroute/test" ]]; then
  "$build/tools/sceneloc-gentour" --out "$out/offroute" --locations 100 --width 960 --height 540 \
    --seed 29 --passes test | tail -n 1
fi
mapfile -t synthetic < <(ls "$out/distractors/tour" 2>/dev/null | sort -V)

# make_tour N: OUT/tours/N, real first (file order is tour order), look-alikes, distractors.
make_tour() {
  local n=$1 dir="$out/tours/$1" i
  rm -rf "$dir"
  mkdir -p "$dir"
  ln -s "$data/gardens_point/day_left"/*.jpg "$dir/"
  local left=$((n - 200))
  for ((i = 0; i < ${#corridor[@]} && left > 0; ++i, --left)); do
    ln -s "${corridor[i]}" "$dir/$(printf 'Look%05d.jpg' "$i")"
  done
  for ((i = 0; left > 0; ++i, --left)); do
    ln -s "$out/distractors/tour/${synthetic[i]}" "$dir/$(printf 'Synth%06d.jpg' "$i")"
  done
}

# Like for like: the generated tour's own first 200 frames, trained alone. The padded maps'
# smallest size is Gardens Point, whose frames hold fewer features than the generated ones;
# training's cost per location at the largest size is compared with this too.
like="$out/generated-200"
if [[ ! ($keep_maps == 1 && -s $like/train.txt) ]] && ((${#synthetic[@]} >= 200)); then
  echo "== 200 generated locations (like for like)"
  rm -rf "$like"
  mkdir -p "$like/tour"
  for ((i = 0; i < 200; ++i)); do ln -s "$out/distractors/tour/${synthetic[i]}" "$like/tour/"; done
  /usr/bin/time -v "$build/tools/sceneloc-train" --tour "$like/tour" --out "$like/map.scnl" \
    --threads "$threads" >"$like/train.txt" 2>"$like/train.err"
  tail -n 1 "$like/train.txt"
fi

hwm_mb() { awk '/VmHWM/ {printf "%.1f", $2 / 1024}' "/proc/$server_pid/status"; }
load_ms() { grep -o 'after [0-9]* ms' "$1" | tail -n 1 | grep -o '[0-9]*'; }

for n in "${sizes[@]}"; do
  echo "== $n locations"
  result="$out/size-$n"
  mkdir -p "$result" "$out/maps-$n"
  map="$out/maps-$n/scale.scnl"
  if [[ $keep_maps == 1 && -s $map && -s $result/train.txt && -s $result/train.err ]]; then
    echo "  the map and training figures of an earlier run (SCENELOC_SCALE_KEEP_MAPS=1)"
  else
    make_tour "$n"
    /usr/bin/time -v "$build/tools/sceneloc-train" --tour "$out/tours/$n" --out "$map" \
      --threads "$threads" >"$result/train.txt" 2>"$result/train.err"
  fi
  tail -n 3 "$result/train.txt"

  # The server's maps folder holds this size's map alone (a hard link: no copy).
  mkdir -p "$out/maps"
  rm -f "$out/maps"/*.scnl
  ln "$map" "$out/maps/scale.scnl"
  start_server "$n" --threads "$threads"
  deadline=$((SECONDS + 600))
  until grep -q 'loaded from' "$out/server-$n.log"; do
    ((SECONDS < deadline)) || { echo "bench_scale: map not loaded" >&2; exit 1; }
    sleep 0.5
  done
  one_map=$(rss_mb)
  first_load=$(load_ms "$out/server-$n.log")
  map_mb=$(grep -o '[0-9.]* MB in memory' "$out/server-$n.log" | head -n 1 | cut -d' ' -f1)
  # A new generation of the same map, loaded beside the one serving: the peak is the most
  # the server holds during a hot reload (VmHWM, reset first: Linux's clear_refs 5).
  echo 5 >"/proc/$server_pid/clear_refs"
  cp "$map" "$out/maps/.scale.new" && mv "$out/maps/.scale.new" "$out/maps/scale.scnl"
  until grep -q 'generation 2' "$out/server-$n.log"; do
    ((SECONDS < deadline)) || { echo "bench_scale: reload not seen" >&2; exit 1; }
    sleep 0.5
  done
  sleep 1  # the old generation is released once no request holds it
  reload_peak=$(hwm_mb)
  reload_ms=$(load_ms "$out/server-$n.log")
  "$client" bench --server "$endpoint" --map scale --clients 1 --duration "$seconds" \
    --json "$result/jpeg.json" "$data/gardens_point/day_right" | grep 'latency ms'
  "$client" bench --server "$endpoint" --map scale --clients 1 --duration "$seconds" --features \
    --map-file "$map" --json "$result/features.json" "$data/gardens_point/day_right" |
    grep 'latency ms'
  stop_server

  "$build/tools/sceneloc-eval" --map "$map" --queries "$data/gardens_point/day_right" \
    --negatives "$out/offroute/test" --sequence --threads "$threads" --json "$result/eval.json" |
    grep -E '^sceneloc|^negatives'
  cat >"$result/server.json" <<EOF
{"rss_one_map_mb": $one_map, "map_memory_mb": $map_mb, "load_ms": $first_load,
 "reload_peak_mb": $reload_peak, "reload_ms": $reload_ms}
EOF
done

/usr/bin/python3 "$root/scripts/scale_report.py" "$out" "${sizes[@]}"
