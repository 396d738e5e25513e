#!/usr/bin/python3
"""Summarises a run of scripts/experiences.sh: reads OUT/evals/*.json (sceneloc-eval),
OUT/frames/*.csv (sceneloc-train --extend --frames-csv), OUT/extend_*.txt and OUT/cost.txt,
checks each target of the experiences issue, prints them and writes OUT/experiences.json.

Usage: scripts/experiences_summary.py OUT VERSION
"""
import csv
import json
import random
import re
import statistics
import sys
from pathlib import Path

BINS = 10
DRAWS = 200


def ece(confidence, correct):
    """Expected calibration error over 10 equal-width bins (tools/eval/confidence_metrics.cc)."""
    total, bins = len(confidence), [[0, 0.0, 0] for _ in range(BINS)]
    for c, ok in zip(confidence, correct):
        b = bins[min(BINS - 1, int(c * BINS))]
        b[0] += 1
        b[1] += c
        b[2] += ok
    return sum(abs(s - k) for n, s, k in bins if n) / total if total else 0.0


def ece_floor(confidence):
    """The ECE a perfectly calibrated confidence shows on as many answers (simulated)."""
    rng = random.Random(1)
    return sum(ece(confidence, [rng.random() < c for c in confidence])
               for _ in range(DRAWS)) / DRAWS


def answers(folder, name):
    run = json.loads((folder / f"{name}.json").read_text())
    rows = [(q["confidence"], q["truth"] >= 0 and abs(q["predicted"] - q["truth"]) <= 2)
            for q in run["per_query"]]
    gross = sum(q["confidence"] >= 0.99 and q["truth"] >= 0 and abs(q["predicted"] - q["truth"]) > 5
                for q in run["per_query"])
    return {"within_2": run["match_rate"]["2"], "queries": len(rows),
            "ece": run["confidence"]["ece"], "ece_floor": run["confidence"]["ece_floor"],
            "correct_accepted": run["confidence"]["correct_accepted"],
            "precision": run["confidence"]["accepted_precision"], "gross_99": gross, "rows": rows}


def number(name):
    m = re.search(r"(\d+)", name)
    return int(m.group(1)) if m else None


def alignment(out, name):
    """Of the walk's added frames, how many were placed within +-2 of their true place."""
    rows = list(csv.DictReader((out / "frames" / f"{name}.csv").open()))
    added = [r for r in rows if r["added"] == "1"]
    right = sum(abs(number(r["place_name"]) - number(r["name"])) <= 2 for r in added)
    return {"frames": len(rows), "added": len(added), "within_2": right,
            "placed_by_session": sum(r["place"] != "-1" and r["bridged"] == "0" for r in rows),
            "bridged": sum(r["bridged"] == "1" for r in rows),
            "recognised": sum(r["recognised"] == "1" for r in rows)}


SETS = ("night_odd@day_left", "night_odd@extended", "day_right@day_left",
        "day_right@extended_night", "night_100@day_left", "night_100@extended",
        "corridor@corridor", "corridor@extended", "day_right@extended_corridor")
EXTENDED = ["night_odd@extended", "day_right@extended_night", "night_100@extended",
            "corridor@extended", "day_right@extended_corridor"]
# The same queries on the maps without the walks (GP day twice: two extended maps answer it).
WITHOUT = ["night_odd@day_left", "day_right@day_left", "night_100@day_left",
           "corridor@corridor", "day_right@day_left"]


def pooled(sets, names):
    rows = [r for n in names for r in sets[n]["rows"]]
    conf = [c for c, _ in rows]
    return {"answers": len(rows), "ece": ece(conf, [ok for _, ok in rows]),
            "ece_floor": ece_floor(conf)}


def main(out, version):
    sets = {name: answers(out / "evals", name) for name in SETS}
    held = {name: answers(out / "held_out" / "evals", name) for name in SETS}
    aligned = {name: alignment(out, name) for name in
               ("day_left+night_even", "day_left+day_right")}
    cost = {"train": [], "extend": [], "train_large": [], "extend_large": []}
    for line in (out / "cost.txt").read_text().splitlines():
        kind, seconds = line.split()[:2] if len(line.split()) >= 2 else ("", "")
        if kind in cost:
            cost[kind].append(float(seconds))
    train_s, extend_s = statistics.median(cost["train"]), statistics.median(cost["extend"])
    train_l = statistics.median(cost["train_large"]) if cost["train_large"] else None
    extend_l = statistics.median(cost["extend_large"]) if cost["extend_large"] else None

    extended, today = pooled(sets, EXTENDED), pooled(sets, WITHOUT)
    held_pooled = {"extended": pooled(held, EXTENDED), "today": pooled(held, WITHOUT)}
    w = lambda n: sets[n]["within_2"]  # noqa: E731
    targets = [
        {"target": "night_right odd 001-099 on day_left + even night frames", "goal": ">= 0.90",
         "before": w("night_odd@day_left"), "after": w("night_odd@extended"),
         "met": w("night_odd@extended") >= 0.90},
        {"target": "day_right 000-099 on that map", "goal": "within 0.02 of day_left alone",
         "before": w("day_right@day_left"), "after": w("day_right@extended_night"),
         "met": w("day_right@extended_night") >= w("day_right@day_left") - 0.02},
        {"target": "night_right 000-099 on day_left + day_right 000-099", "goal": ">= 0.80",
         "before": w("night_100@day_left"), "after": w("night_100@extended"),
         "met": w("night_100@extended") >= 0.80},
        {"target": "corridor queries on day_left + corridor ref (new ground)",
         "goal": "within 0.02 of the corridor map alone", "before": w("corridor@corridor"),
         "after": w("corridor@extended"),
         "met": w("corridor@extended") >= w("corridor@corridor") - 0.02},
        {"target": "day_right 000-099 on day_left + corridor ref", "goal": "unchanged",
         "before": w("day_right@day_left"), "after": w("day_right@extended_corridor"),
         "met": w("day_right@extended_corridor") >= w("day_right@day_left") - 0.02},
    ]
    for name, a in aligned.items():
        share = a["within_2"] / a["added"] if a["added"] else 0.0
        targets.append({"target": f"alignment of {name.split('+')[1]}'s added frames within +-2",
                        "goal": ">= 0.95", "before": None, "after": share, "met": share >= 0.95})
    targets.append({"target": "ECE pooled over the extended maps' sets",
                    "goal": "no worse than today's (its floor beside it)",
                    "before": today["ece"], "after": extended["ece"],
                    "met": extended["ece"] <= max(today["ece"], extended["ece_floor"])})
    targets.append({"target": "cost of extending by 50 frames / training them from scratch",
                    "goal": "<= 1.5", "before": None, "after": extend_s / train_s,
                    "met": extend_s / train_s <= 1.5})
    if train_l and extend_l:
        targets.append({"target": "the same on a generated 1,000-location map",
                        "goal": "<= 1.5", "before": None, "after": extend_l / train_l,
                        "met": extend_l / train_l <= 1.5})
    targets.append({"target": "held out: ECE pooled over the extended maps' sets",
                    "goal": "no worse than today's held out (its floor beside it)",
                    "before": held_pooled["today"]["ece"], "after": held_pooled["extended"]["ece"],
                    "met": held_pooled["extended"]["ece"] <= max(held_pooled["today"]["ece"],
                                                                 held_pooled["extended"]["ece_floor"])})
    gross = sum(held[n]["gross_99"] for n in EXTENDED)
    targets.append({"target": "held out: answers > 5 frames off at confidence >= 0.99, extended maps",
                    "goal": "none", "before": None, "after": gross, "met": gross == 0})
    for s in list(sets.values()) + list(held.values()):
        s.pop("rows")
    result = {"version": version, "sets": sets, "held_out": held,
              "held_out_pooled": held_pooled, "alignment": aligned,
              "ece_pooled": {"extended": extended, "today": today},
              "cost_seconds": {"train_median": train_s, "extend_median": extend_s,
                               "train": cost["train"], "extend": cost["extend"],
                               "train_large_median": train_l, "extend_large_median": extend_l,
                               "train_large": cost["train_large"],
                               "extend_large": cost["extend_large"]},
              "targets": targets, "all_met": all(t["met"] for t in targets)}
    (out / "experiences.json").write_text(json.dumps(result, indent=1) + "\n")
    for t in targets:
        before = "" if t["before"] is None else f"{t['before']:.3f} -> "
        print(f"{'met ' if t['met'] else 'MISS'}  {t['target']}: {before}{t['after']:.3f} "
              f"({t['goal']})")
    print(f"      pooled ECE: extended {extended['ece']:.3f} (floor {extended['ece_floor']:.3f}), "
          f"without the walks {today['ece']:.3f} (floor {today['ece_floor']:.3f})")
    print(f"      held out, pooled ECE: extended {held_pooled['extended']['ece']:.3f} (floor "
          f"{held_pooled['extended']['ece_floor']:.3f}), without the walks "
          f"{held_pooled['today']['ece']:.3f} (floor {held_pooled['today']['ece_floor']:.3f})")
    print(f"      cost: extend {extend_s:.2f} s, train from scratch {train_s:.2f} s (medians of 3)")
    if train_l and extend_l:
        print(f"      1,000 locations: extend {extend_l:.2f} s, train from scratch {train_l:.2f} s")
    print(f"wrote {out / 'experiences.json'}")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(Path(sys.argv[1]), sys.argv[2])
