#!/usr/bin/env python3
"""Re-fits the temperature of the calibrated confidence, leaving each family of sets out.

The confidence (common/matching/confidence.h, evidence.h) is the softmax posterior of every
location's fused evidence at temperature T (at plateau * T within tolerance + 1 of the
answer), summed over the answer's +-tolerance, averaged over cameras within +-2 spreads of
the one the query was read with (the verified candidates re-scored for each; the spread is
MatchOptions::confidence_scale_spread and the camera's doubt in quadrature: FrameCamera in
localiser.h), times P(in the map). T is a constant of the method, not of a map; it
was chosen on the development sets and must be re-checked whenever the evidence changes (a
new descriptor, a new stage).

Reads the per-query evidence of an accuracy-suite run (OUT/accuracy.json from
scripts/accuracy.sh: each query's location scores, verified candidates and P(in the map),
and the run's settings), and:
  1. checks that the confidence recomputed at the run's settings equals the one the suite
     reported (so this script models the engine, not a guess of it);
  2. for each family of sets (Gardens Point day and its generated variants are one family;
     night same side, night other side and the corridor one each), fits T on the *other*
     families by log-loss and reports the held-out family's ECE (10 bins) at the fitted T
     and at the shipped one, beside its sampling floor;
  3. prints the T fitted on every set together.

A new T is worth shipping only if every held-out fit lands near it and held-out ECE does
not rise on any family.

Usage: scripts/fit_confidence.py OUT_DIR [T] [TOLERANCE] [PLATEAU] [SPREAD]
       (defaults: the run's own settings; packages: scripts/setup.sh --plots)
"""
import json
import re
import sys

import numpy as np
from scipy.optimize import minimize_scalar

# The families of sets, ECE and its sampling floor: as the recalibration check has them.
from recalibration_check import FAMILY, ece, ece_floor  # noqa: E402


def setting(yaml_text, name):
    """One numeric or boolean setting of the run (match_settings / train_settings YAML)."""
    m = re.search(r"^\s*" + name + r":\s*(\S+)", yaml_text, re.MULTILINE)
    if not m:
        sys.exit(f"accuracy.json carries no setting {name}: re-run scripts/accuracy.sh")
    value = m.group(1)
    return {"true": 1.0, "false": 0.0}[value] if value in ("true", "false") else float(value)


class Settings:
    """What the confidence depends on besides T (localiser.h MatchOptions)."""

    def __init__(self, match_yaml, tolerance, plateau, spread):
        self.sigma = setting(match_yaml, "verify_scale_sigma")
        self.chance = setting(match_yaml, "verify_chance_inliers")
        self.weight = setting(match_yaml, "verify_weight")
        self.holistic = setting(match_yaml, "use_holistic") > 0
        self.tolerance = tolerance
        self.plateau = plateau
        self.spread = spread


class Query:
    """One query's evidence: near[l] marks the locations within tolerance of the answer."""

    def __init__(self, q, settings):
        e = q["evidence"]
        self.scores = np.asarray(e["scores"], dtype=float)
        self.candidates = [c for c in e.get("candidates", []) if 0 <= c[0] < len(self.scores)]
        self.in_map = e["in_map"]
        # the camera the query was read with and its doubt (absent in older runs: 0, 0)
        self.camera, self.doubt = e.get("camera", (0.0, 0.0))
        self.predicted, self.reported = q["sceneloc"]
        self.settings = settings
        tolerance = settings.tolerance
        self.correct = float(self.predicted >= 0 and abs(self.predicted - q["truth"]) <= tolerance)
        idx = np.arange(len(self.scores))
        self.near = np.abs(idx - self.predicted) <= tolerance
        # the answer's plateau is read at plateau * T (MatchOptions::confidence_plateau)
        self.scale = np.where(np.abs(idx - self.predicted) <= tolerance + 1, settings.plateau, 1.0)

    def scores_at(self, camera):
        """Every location's fused evidence with the candidates scored for `camera`."""
        st, s = self.settings, self.scores.copy()
        for location, z, inliers, m, holistic in self.candidates:
            v = inliers * (np.exp(-(m - camera) ** 2 / (2 * st.sigma ** 2)) if st.sigma > 0 else 1)
            s[location] = (z if st.holistic and holistic >= 0 else 0) + st.weight * max(
                0.0, v - st.chance)
        return s

    def posterior(self, s, t):
        w = np.exp((s - s.max()) / (t * self.scale))
        return w[self.near].sum() / w.sum()

    def confidence(self, t):
        s, st = self.scores, self.settings
        if len(s) == 0 or s.max() == s.min() or self.predicted < 0:
            return 0.0
        if st.spread > 0 and st.sigma > 0 and self.candidates:
            x = np.arange(-4, 5) / 2.0  # +-2 spreads in half spreads (CameraAveragedPosterior)
            w = np.exp(-x * x / 2)
            spread = np.hypot(st.spread, self.doubt)
            p = sum(wi * self.posterior(self.scores_at(self.camera + xi * spread), t)
                    for wi, xi in zip(w, x)) / w.sum()
        else:
            p = self.posterior(s, t)
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
    report = json.load(open(sys.argv[1] + "/accuracy.json"))
    match_yaml, train_yaml = report["match_settings"], report["train_settings"]
    shipped = float(sys.argv[2]) if len(sys.argv) > 2 else setting(train_yaml,
                                                                   "confidence_temperature")
    tolerance = int(sys.argv[3]) if len(sys.argv) > 3 else int(setting(train_yaml, "tolerance"))
    plateau = float(sys.argv[4]) if len(sys.argv) > 4 else setting(match_yaml,
                                                                   "confidence_plateau")
    spread = float(sys.argv[5]) if len(sys.argv) > 5 else setting(match_yaml,
                                                                  "confidence_scale_spread")
    settings = Settings(match_yaml, tolerance, plateau, spread)
    sets = {}
    for s in report["sets"]:
        qs = s.get("per_query", [])
        if qs and "evidence" in qs[0]:
            sets[s["name"]] = [Query(q, settings) for q in qs]
    if not sets:
        sys.exit("no per-query evidence in accuracy.json: re-run scripts/accuracy.sh")

    worst = max(abs(confidences(qs, shipped) - [q.reported for q in qs]).max()
                for qs in sets.values())
    print(f"recomputed at T={shipped}, spread {spread} vs reported: largest difference {worst:.2e}")

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
