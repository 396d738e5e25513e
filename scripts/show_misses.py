#!/usr/bin/python3
"""Shows the answers of one set in an accuracy-suite run that missed the tolerance, each query
beside the tour frames around its ground truth and around the answer given, as
OUT/misses_SET_METHOD.png: to judge by eye whether a miss is the engine's or the ground
truth's (a second walk that runs ahead of or behind the tour, so that "the same file name is
the same place" is off by a few frames).

Usage: scripts/show_misses.py OUT SET [--method M] [--tolerance T]
  OUT  an output folder of sceneloc-accuracy (or scripts/accuracy.sh): its accuracy.json
  SET  a set's name in it, e.g. corridor
  M    sceneloc (single frames, the default), session, in session, baseline, ...
  T    frames (default 2)
Reads the images from the paths the run recorded; generated sets need the run's cache.
Packages: scripts/setup.sh --plots.
"""
import argparse
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

AROUND = 1  # tour frames shown either side of the truth and of the answer


def tour_images(report_set):
    folder = Path(report_set["tour"])
    return sorted(p for p in folder.iterdir() if p.suffix.lower() in (".jpg", ".jpeg", ".png"))


def main(out, set_name, method="sceneloc", tolerance=2):
    report = json.loads((out / "accuracy.json").read_text())
    sets = {s["name"]: s for s in report["sets"]}
    if set_name not in sets:
        sys.exit(f"show_misses: no set '{set_name}' in {out}/accuracy.json ({', '.join(sets)})")
    s = sets[set_name]
    tour = tour_images(s)
    misses = []
    for q in s["per_query"]:
        if method not in q:
            sys.exit(f"show_misses: no method '{method}' in the run ({', '.join(q)})")
        answer = q[method][0]
        if abs(answer - q["truth"]) > tolerance:
            misses.append((q["query"], q["truth"], answer, q[method][1]))
    if not misses:
        print(f"{set_name}, {method}: no answer outside ±{tolerance}")
        return
    cols = 1 + 2 * (2 * AROUND + 1)
    fig, axes = plt.subplots(len(misses), cols, figsize=(1.6 * cols, 1.3 * len(misses)),
                             squeeze=False)
    for row, (query, truth, answer, confidence) in enumerate(misses):
        cells = [(Path(s["queries_dir"]) / query, f"query {Path(query).stem}\n{method} {answer} ({confidence:.2f})")]
        for centre, label in ((truth, "truth"), (answer, "answer")):
            for k in range(centre - AROUND, centre + AROUND + 1):
                path = tour[k] if 0 <= k < len(tour) else None
                cells.append((path, f"{label} {k}" if k == centre else f"tour {k}"))
        for ax, (path, label) in zip(axes[row], cells):
            ax.axis("off")
            if path is not None:
                ax.imshow(plt.imread(path), cmap="gray")
            ax.set_title(label, fontsize=6)
    fig.tight_layout()
    png = out / f"misses_{set_name}_{method.replace(' ', '_')}.png"
    fig.savefig(png, dpi=110)
    print(f"{set_name}, {method}: {len(misses)} answers outside ±{tolerance} -> {png}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("out", type=Path)
    parser.add_argument("set_name", metavar="set")
    parser.add_argument("--method", default="sceneloc")
    parser.add_argument("--tolerance", type=int, default=2)
    args = parser.parse_args()
    main(args.out, args.set_name, args.method, args.tolerance)
