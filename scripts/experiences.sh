#!/usr/bin/env bash
# Maps that grow by walks (sceneloc-train --extend; docs/experiences.md): every target of the
# experiences issue in one run, on the development data, shipped settings, single frames,
# each beside the same queries against the map without the walk:
#   - Gardens Point day_left + the even night_right frames 000-098: the odd night frames
#     001-099, and day_right 000-099;
#   - day_left + day_right 000-099 (another viewpoint): night_right 000-099;
#   - how many of each added walk's frames were aligned within +-2 of their true place
#     (file-name truth, used only to score);
#   - day_left + the corridor's ref as new ground: the corridor queries against the corridor
#     map alone, and day_right 000-099 against day_left alone;
#   - the confidence's ECE pooled over those sets on the extended maps, beside the same on the
#     maps without the walks, each with its sampling floor;
#   - the cost: extending day_left by the 50 night frames against training a map of those 50
#     frames from scratch (median of 3 runs each, one after the other), and the same on a
#     generated 1,000-location map extended by 50 frames of its test pass (whatever the size
#     of the map, the target says);
#   - the same sets again with the confidence's three fitted constants (temperature, in-map
#     slope and offset) fitted without each set's family, as docs/runs/accuracy.json's
#     leave-one-set-out fit has them: ECE beside its floor, precision at 0.8, gross errors.
# Writes OUT/experiences.json (for scripts/results_page.py record experiences) and prints a
# summary. About 7 minutes on 2 cores.
# Usage: scripts/experiences.sh [OUT_DIR] [DATA_DIR]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="$(mkdir -p "${1:-$root/bench-out/experiences}" && cd "${1:-$root/bench-out/experiences}" && pwd)"
data="$(cd "${2:-$root/../shared/data}" && pwd)"
gp="$data/gardens_point"
corridor="$data/corridor"
build="$root/build"
train="$build/tools/sceneloc-train"
eval_bin="$build/tools/sceneloc-eval"
for d in "$gp/day_left" "$gp/day_right" "$gp/night_right" "$corridor/ref" "$corridor/query"; do
  [[ -d "$d" ]] || { echo "${0##*/}: $d is needed" >&2; exit 1; }
done
bash "$root/scripts/build.sh" >/dev/null

# Folders of links: the frames a target names, under their own names.
pick() {  # pick NAME SOURCE FIRST STEP LAST
  local dir="$out/walks/$1"
  rm -rf "$dir" && mkdir -p "$dir"
  for ((i = $3; i <= $5; i += $4)); do
    local f
    f="$(printf 'Image%03d.jpg' "$i")"
    ln -s "$2/$f" "$dir/$f"
  done
}
pick night_even "$gp/night_right" 0 2 98
pick night_odd "$gp/night_right" 1 2 99
pick night_100 "$gp/night_right" 0 1 99
pick day_right_100 "$gp/day_right" 0 1 99
walks="$out/walks"
maps="$out/maps"
mkdir -p "$maps" "$out/evals" "$out/frames"

"$train" --tour "$gp/day_left" --out "$maps/day_left.scnl" >"$out/train_day_left.txt"
"$train" --tour "$corridor/ref" --out "$maps/corridor.scnl" >"$out/train_corridor.txt"
extend() {  # extend NAME WALK [FLAGS]
  local name=$1 walk=$2
  shift 2
  "$train" --extend "$maps/day_left.scnl" --tour "$walk" --out "$maps/$name.scnl" \
    --frames-csv "$out/frames/$name.csv" "$@" >"$out/extend_$name.txt"
}
extend day_left+night_even "$walks/night_even"
extend day_left+day_right "$walks/day_right_100"
extend day_left+corridor "$corridor/ref" --new-ground
evaluate() {  # evaluate MAP QUERIES NAME
  "$eval_bin" --map "$maps/$1.scnl" --queries "$2" --json "$out/evals/$3.json" >/dev/null
}
evaluate day_left "$walks/night_odd" night_odd@day_left
evaluate day_left+night_even "$walks/night_odd" night_odd@extended
evaluate day_left "$walks/day_right_100" day_right@day_left
evaluate day_left+night_even "$walks/day_right_100" day_right@extended_night
evaluate day_left "$walks/night_100" night_100@day_left
evaluate day_left+day_right "$walks/night_100" night_100@extended
evaluate corridor "$corridor/query" corridor@corridor
evaluate day_left+corridor "$corridor/query" corridor@extended
evaluate day_left+corridor "$walks/day_right_100" day_right@extended_corridor

# Held out: each set read on maps whose confidence constants were fitted without its family
# (gp_day, gp_night_*, corridor in the accuracy suite's leave-one-set-out fit).
held="$out/held_out"
mkdir -p "$held/maps" "$held/evals"
/usr/bin/python3 - "$root/docs/runs/accuracy.json" "$root/configs/train.yaml" "$held" <<'PY'
import json, re, sys
fits = {s["set"]: s["fitted"] for s in json.load(open(sys.argv[1]))["leave_one_out"]["sets"]}
base = open(sys.argv[2]).read()
for family, set_name in (("day", "gp_day"), ("night", "gp_night_other"), ("corridor", "corridor")):
    f = fits[set_name]
    text = base
    for key, value in (("confidence_temperature", f["temperature"]),
                       ("map_evidence_slope", f["slope"]), ("map_evidence_offset", f["offset"])):
        text, n = re.subn(rf"(\n\s*{key}:)\s*[-0-9.e]+", rf"\g<1> {value!r}", text)
        assert n == 1, key
    open(f"{sys.argv[3]}/{family}.yaml", "w").write(text)
PY
for family in day night corridor; do
  "$train" --tour "$gp/day_left" --out "$held/maps/day_left_$family.scnl" \
    --config "$held/$family.yaml" >/dev/null
done
"$train" --tour "$corridor/ref" --out "$held/maps/corridor.scnl" --config "$held/corridor.yaml" \
  >/dev/null
held_extend() {  # held_extend NAME FAMILY WALK [FLAGS]
  local name=$1 family=$2 walk=$3
  shift 3
  "$train" --extend "$held/maps/day_left_$family.scnl" --tour "$walk" --out "$held/maps/$name.scnl" \
    "$@" >/dev/null
}
held_extend night_even@night night "$walks/night_even"
held_extend night_even@day day "$walks/night_even"
held_extend day_right@night night "$walks/day_right_100"
held_extend corridor@corridor corridor "$corridor/ref" --new-ground
held_extend corridor@day day "$corridor/ref" --new-ground
held_evaluate() {  # held_evaluate MAP QUERIES NAME
  "$eval_bin" --map "$held/maps/$1.scnl" --queries "$2" --json "$held/evals/$3.json" >/dev/null
}
held_evaluate day_left_night "$walks/night_odd" night_odd@day_left
held_evaluate night_even@night "$walks/night_odd" night_odd@extended
held_evaluate day_left_day "$walks/day_right_100" day_right@day_left
held_evaluate night_even@day "$walks/day_right_100" day_right@extended_night
held_evaluate day_left_night "$walks/night_100" night_100@day_left
held_evaluate day_right@night "$walks/night_100" night_100@extended
held_evaluate corridor "$corridor/query" corridor@corridor
held_evaluate corridor@corridor "$corridor/query" corridor@extended
held_evaluate corridor@day "$walks/day_right_100" day_right@extended_corridor

# The cost, one run after the other (never two timings at once).
: >"$out/cost.txt"
for _ in 1 2 3; do
  /usr/bin/time -f "train %e" "$train" --tour "$walks/night_even" --out "$out/scratch.scnl" \
    2>>"$out/cost.txt" >/dev/null
  /usr/bin/time -f "extend %e" "$train" --extend "$maps/day_left.scnl" --tour "$walks/night_even" \
    --out "$out/scratch.scnl" 2>>"$out/cost.txt" >/dev/null
done
# The same on a large map: a generated 1,000-location tour, extended by 50 frames of the same
# street's other pass (frames 100-149).
large="$out/large"
if [[ ! -f "$large/map.scnl" ]]; then
  rm -rf "$large" && mkdir -p "$large/walk"
  "$build/tools/sceneloc-gentour" --out "$large/tour" --locations 1000 --threads 2 >/dev/null
  "$train" --tour "$large/tour/tour" --out "$large/map.scnl" --threads 2 >/dev/null 2>&1
  for f in $(ls "$large/tour/test" | sort | sed -n '101,150p'); do
    ln -s "$large/tour/test/$f" "$large/walk/$f"
  done
fi
for _ in 1 2 3; do
  /usr/bin/time -f "train_large %e" "$train" --tour "$large/walk" --out "$out/scratch.scnl" \
    --threads 2 2>>"$out/cost.txt" >/dev/null
  /usr/bin/time -f "extend_large %e" "$train" --extend "$large/map.scnl" --tour "$large/walk" \
    --out "$out/scratch.scnl" --threads 2 2>>"$out/cost.txt" >"$out/extend_large.txt"
done
rm -f "$out/scratch.scnl"

/usr/bin/python3 "$root/scripts/experiences_summary.py" "$out" "$("$train" --version)"
