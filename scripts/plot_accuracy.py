#!/usr/bin/python3
"""Plots OUT/accuracy.json of sceneloc-accuracy: match rate within ±2 frames (bars) and ±3
(ticks) per set and method, as OUT/accuracy.png."""
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

METHODS = [("sceneloc", "#1f77b4"), ("session", "#17becf"), ("paper", "#9467bd"),
           ("baseline", "#7f7f7f"), ("baseline+ransac", "#bcbd22")]


def main(out):
    report = json.loads((out / "accuracy.json").read_text())
    sets = report["sets"]
    width = 0.8 / len(METHODS)
    fig, ax = plt.subplots(figsize=(max(8, 1.4 * len(sets)), 4.5))
    for m, (method, colour) in enumerate(METHODS):
        xs = [i + (m - (len(METHODS) - 1) / 2) * width for i in range(len(sets))]
        r2 = [s["methods"][method]["match_rate"]["2"] for s in sets]
        r3 = [s["methods"][method]["match_rate"]["3"] for s in sets]
        ax.bar(xs, r2, width, color=colour, label=method)
        ax.scatter(xs, r3, marker="_", s=120, color="black", zorder=3)
    ax.set_xticks(range(len(sets)))
    ax.set_xticklabels([f'{s["name"]}\n({s["queries"]} queries)' for s in sets], fontsize=8)
    ax.set_ylim(0, 1.12)
    ax.set_ylabel("match rate within ±2 frames (ticks: ±3)")
    ax.set_title(f'sceneloc accuracy suite, {report["threads"]} threads, host {report["host"]}')
    ax.legend(loc="upper center", fontsize=8, ncol=4)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "accuracy.png", dpi=110)
    print(f"wrote {out / 'accuracy.png'}")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "accuracy-out"))
