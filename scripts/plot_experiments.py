#!/usr/bin/python3
"""Plots the CSVs of scripts/experiments.sh: eta sweep (paper Fig. 5) and eta_opt
against environment size (Fig. 6), with the baseline on the same axes."""
import csv
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def eta_label(eta):
    return "all" if int(eta) == 0 else str(eta)


def plot_eta(out):
    data = rows(out / "eta.csv")
    labels = [eta_label(r["eta"]) for r in data]
    x = range(len(data))
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    for k, style in (("2", "-o"), ("3", "--o")):
        axes[0].plot(x, [float(r["rate" + k]) for r in data], style, label=f"sceneloc ±{k}")
        axes[0].plot(x, [float(r["baseline_rate" + k]) for r in data], style, color="grey",
                     label=f"baseline ±{k}")
    axes[0].set_ylabel("match rate")
    axes[1].plot(x, [float(r["confidence"]) for r in data], "-o", label="sceneloc")
    axes[1].plot(x, [float(r["baseline_confidence"]) for r in data], "-o", color="grey",
                 label="baseline")
    axes[1].set_ylabel("mean confidence (ours: calibrated; baseline: vote share)")
    axes[2].plot(x, [float(r["match_ms_median"]) for r in data], "-o", label="sceneloc")
    axes[2].plot(x, [float(r["baseline_ms_median"]) for r in data], "-o", color="grey",
                 label="baseline")
    axes[2].set_ylabel("matching time per query, median (ms)")
    for ax in axes:
        ax.set_xticks(list(x), labels)
        ax.set_xlabel("η (landmarks per image)")
        ax.grid(alpha=0.3)
        ax.legend()
    fig.suptitle(f"η sweep, {data[0]['locations']} locations (cf. paper Fig. 5)")
    fig.tight_layout()
    fig.savefig(out / "eta_sweep.png", dpi=110)


def plot_size(out):
    data = rows(out / "size.csv")
    best = {}
    for r in data:
        n = int(r["locations"])
        if n not in best or float(r["rate2"]) > float(best[n]["rate2"]):
            best[n] = r
    sizes = sorted(best)
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    ax[0].plot(sizes, [int(best[n]["eta"]) or None for n in sizes], "-o")
    ax[0].set_ylabel("η_opt (best ±2 match rate; 'all' not drawn)")
    ax[1].plot(sizes, [float(best[n]["rate2"]) for n in sizes], "-o", label="sceneloc at η_opt ±2")
    ax[1].plot(sizes, [float(best[n]["baseline_rate2"]) for n in sizes], "-o", color="grey",
               label="baseline ±2")
    ax[1].set_ylabel("match rate")
    for a in ax:
        a.set_xlabel("environment size (tour locations)")
        a.grid(alpha=0.3)
    ax[1].legend()
    fig.suptitle("η_opt against environment size (cf. paper Fig. 6)")
    fig.tight_layout()
    fig.savefig(out / "eta_opt_vs_size.png", dpi=110)


def table(path, first_column):
    """A markdown table of one CSV: ours and the baseline side by side."""
    lines = [f"| {first_column} | locations | η | landmarks | exact | ±1 | ±2 | ±3 | confidence "
             "| match ms (median) | baseline ±2 | baseline ±3 |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows(path):
        lines.append(
            f"| {r['variant']} | {r['locations']} | {eta_label(r['eta'])} | {r['landmarks']} "
            f"| {r['rate0']} | {r['rate1']} | **{r['rate2']}** | **{r['rate3']}** "
            f"| {r['confidence']} | {r['match_ms_median']} | {r['baseline_rate2']} "
            f"| {r['baseline_rate3']} |")
    return "\n".join(lines) + "\n"


def main():
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "docs/experiments")
    tables = []
    # The ablation (ablation.csv) is the accuracy suite's, in its own format: docs/results.md.
    for name, title in (("eta", "run"), ("size", "run")):
        if (out / f"{name}.csv").exists():
            tables.append(f"### {name}\n\n" + table(out / f"{name}.csv", title))
    if (out / "eta.csv").exists():
        plot_eta(out)
    if (out / "size.csv").exists():
        plot_size(out)
    (out / "tables.md").write_text("\n".join(tables))
    print(f"plots and tables written to {out}")


if __name__ == "__main__":
    main()
