#!/usr/bin/env python3
"""Re-fits the temperature of the calibrated confidence, leaving each family of sets out.

The confidence (common/matching/confidence.h) is the softmax posterior of every location's
fused evidence at temperature T (at plateau * T within tolerance + 1 of the answer),
summed over the answer's +-tolerance, times P(in the map). T is a constant of the method, not of a map; it was chosen on the development sets
and must be re-checked whenever the evidence changes (a new descriptor, a new stage).

Reads the per-query evidence of an accuracy-suite run (OUT/accuracy.json from
scripts/accuracy.sh: each query's location scores and P(in the map)), and:
  1. checks that the confidence recomputed at the shipped T equals the one the suite
     reported (so this script models the engine, not a guess of it);
  2. for each family of sets (Gardens Point day and its generated variants are one family;
     night same side, night other side and the corridor one each), fits T on the *other*
     families by log-loss and reports the held-out family's ECE (10 bins) at the fitted T
     and at the shipped one, beside its sampling floor;
  3. prints the T fitted on every set together.

A new T is worth shipping only if every held-out fit lands near it and held-out ECE does
not rise on any family.

Usage: scripts/fit_confidence.py OUT_DIR [SHIPPED_T] [TOLERANCE] [PLATEAU]
       (packages: scripts/setup.sh --plots)
"""
import json
import sys

import numpy as np
from scipy.optimize import minimize_scalar

# The families of sets, ECE and its sampling floor: as the recalibration check has them.
from recalibration_check import FAMILY, ece, ece_floor  # noqa: E402


class Query:
    """One query's evidence: near[l] marks the locations within tolerance of the answer."""

    def __init__(self, q, tolerance, plateau):
        self.scores = np.asarray(q["evidence"]["scores"], dtype=float)
        self.in_map = q["evidence"]["in_map"]
        self.predicted, self.reported = q["sceneloc"]
        self.correct = float(self.predicted >= 0 and abs(self.predicted - q["truth"]) <= tolerance)
        idx = np.arange(len(self.scores))
        self.near = np.abs(idx - self.predicted) <= tolerance
        # the answer's plateau is read at plateau * T (MatchOptions::confidence_plateau)
        self.scale = np.where(np.abs(idx - self.predicted) <= tolerance + 1, plateau, 1.0)

    def confidence(self, t):
        s = self.scores
        if len(s) == 0 or s.max() == s.min() or self.predicted < 0:
            return 0.0
        w = np.exp((s - s.max()) / (t * self.scale))
        p = w[self.near].sum() / w.sum()
        return p * (self.in_map if self.in_map >= 0 else 1.0)


def confidences(queries, t):
    return np.array([q.confidence(t) for q in queries])


def labels(queries):
    return np.array([q.correct for q in queries])


def log_loss(queries, t):
    p = np.clip(confidences(queries, t), 1e-6, 1 - 1e-6)
    y = labels(queries)
    return float(-np.mean(y * np.log(p) + (1 - y) * np.log(1 - p)))


def fit(queries):
    return minimize_scalar(lambda t: log_loss(queries, t), bounds=(0.05, 2.0),
                           method="bounded").x


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    shipped = float(sys.argv[2]) if len(sys.argv) > 2 else 0.28
    tolerance = int(sys.argv[3]) if len(sys.argv) > 3 else 2
    plateau = float(sys.argv[4]) if len(sys.argv) > 4 else 2.0
    report = json.load(open(sys.argv[1] + "/accuracy.json"))
    sets = {}
    for s in report["sets"]:
        qs = s.get("per_query", [])
        if qs and "evidence" in qs[0]:
            sets[s["name"]] = [Query(q, tolerance, plateau) for q in qs]
    if not sets:
        sys.exit("no per-query evidence in accuracy.json: re-run scripts/accuracy.sh")

    worst = max(abs(confidences(qs, shipped) - [q.reported for q in qs]).max()
                for qs in sets.values())
    print(f"recomputed at T={shipped} vs reported: largest difference {worst:.2e}")

    families = sorted({FAMILY.get(n, "gp_day") for n in sets})
    print(f"\n{'held out':12} {'fit on rest':>11} | {'set':18} {'ECE @fit':>8} "
          f"{'ECE @shipped':>12} {'floor':>6}")
    for fam in families:
        rest = [q for n, qs in sets.items() if FAMILY.get(n, "gp_day") != fam for q in qs]
        t = fit(rest)
        for n, qs in sets.items():
            if FAMILY.get(n, "gp_day") != fam:
                continue
            y = labels(qs)
            p_fit, p_ship = confidences(qs, t), confidences(qs, shipped)
            print(f"{fam:12} {t:11.3f} | {n:18} {ece(p_fit, y):8.3f} {ece(p_ship, y):12.3f} "
                  f"{ece_floor(p_ship):6.3f}")
    everything = [q for qs in sets.values() for q in qs]
    print(f"\nT fitted on every set: {fit(everything):.3f} (shipped {shipped})")


if __name__ == "__main__":
    main()
