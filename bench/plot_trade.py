#!/usr/bin/python3
"""Plots the speed-accuracy trade written by `dem trade`: error against cost, log-log.

Reads trade.csv (and trade_metrics.txt beside it, for units and the reference's own error), and writes
trade.png beside it (or --out): one series per control and method (fixed steps labelled with dt, step
doubling with its tolerance), the Pareto front (settings no other setting beats on both cost and
error) as a dashed line, the reference's error estimate and the noise floor as horizontal lines, and
diverged settings as crosses along the top.

usage: bench/plot_trade.py out/SCENE/trade/trade.csv [--metric position_max] [--cost particle_steps]
                           [--out trade.png]
Needs Debian's python3-matplotlib (apt-get install python3-matplotlib).
"""
import argparse
import csv
import math
import os
import sys


def number(text):
    try:
        return float(text)
    except (TypeError, ValueError):
        return math.nan


def pareto(points):
    """The points no other point beats on both cost and error, by increasing cost."""
    front, best = [], math.inf
    for cost, error in sorted(points):
        if error < best:
            front.append((cost, error))
            best = error
    return front


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("csv", help="trade.csv written by dem trade")
    parser.add_argument("--metric", help="error column without _error (default: the first)")
    parser.add_argument("--cost", default="particle_steps", choices=["particle_steps", "wall_time", "force_evaluations"])
    parser.add_argument("--out", help="PNG to write (default: trade.png beside the CSV)")
    args = parser.parse_args()

    with open(args.csv) as f:
        reader = csv.DictReader(f)
        rows = list(reader)
        columns = reader.fieldnames or []
    metrics = [c[: -len("_error")] for c in columns if c.endswith("_error")]
    if not metrics:
        sys.exit(f"{args.csv}: no <metric>_error column")
    metric = args.metric or metrics[0]
    if metric not in metrics:
        sys.exit(f"{args.csv}: no metric {metric}; there are: {', '.join(metrics)}")

    folder = os.path.dirname(os.path.abspath(args.csv))
    unit, reference_error = "", math.nan
    metrics_file = os.path.join(folder, "trade_metrics.txt")
    if os.path.exists(metrics_file):
        with open(metrics_file) as f:
            for r in csv.DictReader(f):
                if r["metric"] == metric:
                    unit, reference_error = r["unit"], number(r["reference_error"])

    scene = os.path.basename(os.path.dirname(folder)) or folder
    reference_file = os.path.join(folder, "trade_reference.txt")
    if os.path.exists(reference_file):
        with open(reference_file) as f:
            for r in csv.DictReader(f):
                if r["key"] == "scene":
                    scene = os.path.splitext(os.path.basename(r["value"]))[0]

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5))
    finite, diverged = [], []
    series = {}
    for r in rows:
        cost, error = number(r[args.cost]), number(r[metric + "_error"])
        label = f"dt = {number(r['dt']):g}" if r["control"] == "fixed" else f"tol = {number(r['tolerance']):g}"
        if r["status"] != "ok" or not math.isfinite(error) or not cost > 0:
            diverged.append((cost, label))
            continue
        error = max(error, 1e-300)
        finite.append((cost, error))
        series.setdefault((r["control"], r["method"]), []).append((cost, error, label))
    styles = {"fixed": ("o", "-"), "doubling": ("s", "-")}
    for (control, method), points in sorted(series.items()):
        points.sort()
        marker, line = styles.get(control, ("^", "-"))
        ax.plot([p[0] for p in points], [p[1] for p in points], marker=marker, linestyle=line,
                label=f"{control} ({method})")
        for cost, error, label in points:
            ax.annotate(label, (cost, error), textcoords="offset points", xytext=(4, 4), fontsize=7)
    front = pareto(finite)
    if front:
        ax.plot([p[0] for p in front], [p[1] for p in front], color="black", ls="--", lw=2.5, alpha=0.25, zorder=0,
                label="Pareto front")
    if math.isfinite(reference_error) and reference_error > 0:
        ax.axhline(reference_error, color="grey", ls=":", lw=1, label="reference error estimate")
    noise = [number(r.get(metric + "_noise")) for r in rows]
    noise = [n for n in noise if math.isfinite(n) and n > 0]
    if noise:
        ax.axhline(max(noise), color="red", ls=":", lw=1, label="noise floor (perturbed references)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    if diverged:
        top = ax.get_ylim()[1] if finite else 1.0
        for cost, label in diverged:
            if cost > 0:
                ax.plot([cost], [top], "rx")
                ax.annotate(f"{label}: diverged", (cost, top), textcoords="offset points", xytext=(4, -10),
                            fontsize=7, color="red")
    cost_names = {"particle_steps": "particle-steps (all trials)", "wall_time": "wall time [s]",
                  "force_evaluations": "force evaluations"}
    ax.set_xlabel(f"cost: {cost_names[args.cost]}")
    ax.set_ylabel(f"{metric} error" + (f" [{unit}]" if unit else ""))
    ax.set_title(f"Speed-accuracy trade: {scene}")
    ax.grid(True, which="both", alpha=0.25)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8)
    fig.tight_layout()
    out = args.out or os.path.join(folder, "trade.png")
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
