#!/usr/bin/env python3
"""Would a post-hoc recalibration of the confidence transfer across data sets?

Reads the per-query answers of an accuracy-suite run (OUT/accuracy.json from
scripts/accuracy.sh) and, for every set, fits a Platt map p' = sigmoid(a logit(p) + b) on
the *other* families of sets (Gardens Point day and its generated variants are one family,
night same side, night other side and the corridor one each), then reports the held-out
set's expected calibration error (10 bins) before and after, beside its sampling floor
(the ECE a perfectly calibrated confidence would show with this many queries).

docs/results.md quotes one run: it helped the day family and hurt the corridor and night
on the other side, so the shipped confidence has no such step.

Usage: scripts/recalibration_check.py OUT_DIR   (packages: scripts/setup.sh --plots)
"""
import json
import sys

import numpy as np
from scipy.optimize import minimize

FAMILY = {"gp_night_same": "night_same", "gp_night_other": "night_other",
          "corridor": "corridor"}  # every other set: the Gardens Point day family


def ece(p, y, bins=10):
    b = np.minimum((p * bins).astype(int), bins - 1)
    return sum((b == i).sum() / len(p) * abs(p[b == i].mean() - y[b == i].mean())
               for i in range(bins) if (b == i).any())


def ece_floor(p, draws=400, rng=np.random.default_rng(0)):
    return float(np.mean([ece(p, (rng.random(len(p)) < p).astype(float)) for _ in range(draws)]))


def logit(p):
    p = np.clip(p, 1e-4, 1 - 1e-4)
    return np.log(p / (1 - p))


def fit_platt(p, y):
    x = logit(p)

    def loss(ab):
        q = np.clip(1 / (1 + np.exp(-(ab[0] * x + ab[1]))), 1e-9, 1 - 1e-9)
        return -np.mean(y * np.log(q) + (1 - y) * np.log(1 - q))

    return minimize(loss, [1.0, 0.0]).x


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    with open(f"{sys.argv[1]}/accuracy.json") as f:
        run = json.load(f)
    sets = {}
    for s in run["sets"]:
        tolerance = 2
        p = np.array([q["sceneloc"][1] for q in s["per_query"]])
        y = np.array([abs(q["sceneloc"][0] - q["truth"]) <= tolerance
                      for q in s["per_query"]], dtype=float)
        sets[s["name"]] = (p, y)
    print(f"{'held out':16} {'n':>4} {'ECE':>6} {'floor':>6}   {'a':>5} {'b':>5}   "
          f"{'ECE':>6} {'floor':>6}  (after the map fitted on the other families)")
    for name, (p, y) in sets.items():
        family = FAMILY.get(name, "day")
        train = [n for n in sets if FAMILY.get(n, "day") != family]
        a, b = fit_platt(np.concatenate([sets[n][0] for n in train]),
                         np.concatenate([sets[n][1] for n in train]))
        q = 1 / (1 + np.exp(-(a * logit(p) + b)))
        print(f"{name:16} {len(p):4d} {ece(p, y):6.3f} {ece_floor(p):6.3f}   {a:5.2f} {b:5.2f}"
              f"   {ece(q, y):6.3f} {ece_floor(q):6.3f}")


if __name__ == "__main__":
    main()
