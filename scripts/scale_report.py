#!/usr/bin/python3
"""The table, JSON and plot of scripts/bench_scale.sh from its OUT folder: every figure per
map size, the largest size's over the smallest's, its slope against the size (log-log, between the two largest sizes: 1 = linear) and
its projection to 100,000 locations along that slope.
Usage: scale_report.py OUT SIZE [SIZE ...]"""
import json
import math
import re
import subprocess
import sys
from pathlib import Path


def train_figures(folder):
    text = (folder / "train.txt").read_text()
    err = (folder / "train.err").read_text()
    total = float(re.search(r"trained .* in ([0-9.]+) s", text).group(1))
    extract = float(re.search(r"extract ([0-9.]+)", text).group(1))
    map_mb = float(re.search(r"map file\s+([0-9.]+) MB", text).group(1))
    features = float(re.search(r"features\s+([0-9]+)", text).group(1))
    rss_kb = float(re.search(r"Maximum resident set size \(kbytes\): ([0-9]+)", err).group(1))
    return total, extract, map_mb, rss_kb / 1024, features


def size_row(out, n):
    folder = out / f"size-{n}"
    total, extract, map_mb, train_rss, tour_features = train_figures(folder)
    server = json.loads((folder / "server.json").read_text())
    jpeg = json.loads((folder / "jpeg.json").read_text())
    features = json.loads((folder / "features.json").read_text())
    ev = json.loads((folder / "eval.json").read_text())
    # With --sequence the report's own figures are the session's; the single frames' sit
    # under session.single_frame.
    single = ev["session"]["single_frame"] if "session" in ev else ev
    conf = single["confidence"]
    neg = ev.get("negatives", {})
    return {
        "locations": n,
        "train_s": total,
        "train_s_but_extraction": total - extract,
        "train_ms_per_location_but_extraction": 1000 * (total - extract) / n,
        # Generated distractor frames hold more features than Gardens Point's (about 900
        # against 550 a frame): the cost per feature is the same work at every size.
        "features_per_location": tour_features / n,
        "train_us_per_feature_but_extraction": 1e6 * (total - extract) / tour_features,
        "train_peak_rss_mb": train_rss,
        "map_file_mb": map_mb,
        "map_memory_mb": server["map_memory_mb"],
        "map_kb_per_location": 1000 * server["map_memory_mb"] / n,
        "server_rss_mb": server["rss_one_map_mb"],
        "load_s": server["load_ms"] / 1000,
        "reload_peak_rss_mb": server["reload_peak_mb"],
        "reload_peak_over_one_map": server["reload_peak_mb"] / server["rss_one_map_mb"],
        "jpeg_p50_ms": jpeg["latency_ms"]["p50"],
        "jpeg_p99_ms": jpeg["latency_ms"]["p99"],
        "features_p50_ms": features["latency_ms"]["p50"],
        "features_p99_ms": features["latency_ms"]["p99"],
        "match_2": single["match_rate"]["2"],
        "localised_precision": conf["accepted_precision"],
        "offroute_localised": neg.get("accepted", 0) / max(1, neg.get("frames", 1)),
        **session_figures(ev),
    }


def session_figures(ev):
    """The queries in route order as one robot's session (sceneloc-eval --sequence)."""
    session = ev.get("session")
    if session is None:
        return {}
    return {"session_filter_ms": session["filter_ms_median"],
            "session_match_2": ev["match_rate"]["2"]}


COLUMNS = [
    ("train_s", "training s", "{:.0f}"),
    ("train_ms_per_location_but_extraction", "but extraction, ms/location", "{:.1f}"),
    ("features_per_location", "tour features per location", "{:.0f}"),
    ("train_us_per_feature_but_extraction", "but extraction, us/feature", "{:.1f}"),
    ("train_peak_rss_mb", "training peak RSS MB", "{:.0f}"),
    ("map_file_mb", "map file MB", "{:.1f}"),
    ("map_kb_per_location", "map in RAM KB/location", "{:.1f}"),
    ("load_s", "load s", "{:.2f}"),
    ("reload_peak_over_one_map", "reload peak / one map (server RSS)", "{:.2f}"),
    ("jpeg_p50_ms", "JPEG p50 ms", "{:.1f}"),
    ("jpeg_p99_ms", "JPEG p99 ms", "{:.1f}"),
    ("features_p50_ms", "feature set p50 ms", "{:.1f}"),
    ("features_p99_ms", "feature set p99 ms", "{:.1f}"),
    ("match_2", "±2 (GP day_right)", "{:.2f}"),
    ("localised_precision", "LOCALISED precision", "{:.3f}"),
    ("offroute_localised", "off-route LOCALISED", "{:.3f}"),
    ("session_filter_ms", "session filter ms/frame (p50)", "{:.3f}"),
    ("session_match_2", "±2 in a session", "{:.2f}"),
]


def version():
    """The build's --version (the commit its figures were made at), for the results page."""
    train = Path(__file__).resolve().parent.parent / "build" / "tools" / "sceneloc-train"
    try:
        return subprocess.run([str(train), "--version"], capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return None


def slope(rows, key):
    a, b = rows[-2], rows[-1]
    if a[key] <= 0 or b[key] <= 0 or a["locations"] == b["locations"]:
        return None
    return math.log(b[key] / a[key]) / math.log(b["locations"] / a["locations"])


def main(out, sizes):
    rows = [size_row(out, n) for n in sizes]
    first, last = rows[0]["locations"], rows[-1]["locations"]
    lines = ["| figure | " + " | ".join(f"{r['locations']:,}" for r in rows) +
             f" | {last:,} / {first:,} | slope | at 100,000 |", "|---" * (len(rows) + 4) + "|"]
    report = {"sizes": rows, "ratios": {}, "slopes": {}, "at_100000": {}, "version": version()}
    for key, label, fmt in COLUMNS:
        if not all(key in r for r in rows):
            continue  # a figure an older run of the benchmark did not measure
        cells = [fmt.format(r[key]) for r in rows]
        s = slope(rows, key) if len(rows) > 1 else None
        projected = None
        if s is not None and key not in ("match_2", "localised_precision", "offroute_localised",
                                         "reload_peak_over_one_map", "session_match_2"):
            projected = rows[-1][key] * (100000 / rows[-1]["locations"]) ** s
        ratio = rows[-1][key] / rows[0][key] if rows[0][key] > 0 else None
        report["ratios"][key] = ratio
        report["slopes"][key] = s
        report["at_100000"][key] = projected
        lines.append(f"| {label} | " + " | ".join(cells) +
                     f" | {'' if ratio is None else f'{ratio:.2f}'}"
                     f" | {'' if s is None else f'{s:.2f}'} | "
                     f"{'' if projected is None else fmt.format(projected)} |")
    like = out / "generated-200"
    if (like / "train.txt").exists():
        # The largest size against a tour of the same generated frames at the smallest.
        total, extract, _, _, tour_features = train_figures(like)
        ms = 1000 * (total - extract) / 200
        report["like_for_like"] = {
            "locations": 200,
            "features_per_location": tour_features / 200,
            "train_ms_per_location_but_extraction": ms,
            "largest_over_it": rows[-1]["train_ms_per_location_but_extraction"] / ms,
        }
        lines.append("")
        lines.append(f"all but extraction, 200 generated locations: {ms:.1f} ms/location "
                     f"({tour_features / 200:.0f} features); {last:,} over it: "
                     f"{report['like_for_like']['largest_over_it']:.2f}")
    table = "\n".join(lines)
    print(table)
    (out / "scale.md").write_text(table + "\n")
    (out / "scale.json").write_text(json.dumps(report, indent=2) + "\n")
    plot(out, rows)


def plot(out, rows):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    sizes = [r["locations"] for r in rows]
    panels = [("training s (all but extraction)", ["train_s_but_extraction"]),
              ("MB", ["map_memory_mb", "train_peak_rss_mb"]),
              ("request ms", ["jpeg_p50_ms", "features_p50_ms", "jpeg_p99_ms", "features_p99_ms"]),
              ("rate", ["match_2", "localised_precision", "offroute_localised"])]
    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.8))
    for ax, (title, keys) in zip(axes, panels):
        for key in keys:
            ax.plot(sizes, [r[key] for r in rows], marker="o", label=key)
        ax.set_xscale("log")
        if title != "rate":
            ax.set_yscale("log")
        ax.set_xlabel("locations")
        ax.set_title(title, fontsize=10)
        ax.legend(fontsize=7)
        ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "scale.png", dpi=110)


if __name__ == "__main__":
    main(Path(sys.argv[1]), [int(n) for n in sys.argv[2:]])
