#!/usr/bin/env python3
"""Plots the collision energy spectra a mill run wrote (spectra.csv) to spectra.png beside it:
events per second against energy, one panel per quantity (impact energy, normal and tangential
energy dissipated per contact event), one line per kind (ball-ball and ball-liner, or with
mill.size_classes each pair of classes and each class with the liner; the classes' radius ranges
come from summary.json beside it when it is there). Debian: python3-matplotlib."""
import csv
import json
import os
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def class_labels(path):
    """Class name -> "c0 (r < 2 mm)" from summary.json's collision_spectra block, if any."""
    summary = os.path.join(os.path.dirname(os.path.abspath(path)), "summary.json")
    try:
        with open(summary) as f:
            classes = json.load(f)["collision_spectra"]["classes"]
    except (OSError, KeyError, ValueError):
        return {}
    labels = {}
    for name, c in classes.items():
        low, high = c.get("radius_min", 0), c.get("radius_max")
        if high is None and low == 0:
            continue
        if high is None:
            labels[name] = "%s (r >= %g mm)" % (name, low * 1e3)
        elif low == 0:
            labels[name] = "%s (r < %g mm)" % (name, high * 1e3)
        else:
            labels[name] = "%s (%g <= r < %g mm)" % (name, low * 1e3, high * 1e3)
    return labels


def main(path):
    rows = defaultdict(list)
    kinds = []  # in the file's order
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            rows[(r["quantity"], r["kind"])].append(r)
            if r["kind"] not in kinds:
                kinds.append(r["kind"])
    labels = class_labels(path)
    quantities = ["impact_energy", "normal_dissipated", "tangential_dissipated"]
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.6), sharey=True)
    for ax, q in zip(axes, quantities):
        for kind in kinds:
            style = "--" if kind.endswith("-liner") else "-"
            # The end bins (edges 0 and inf) gather everything outside the range: not drawn on log axes.
            data = sorted((r for r in rows.get((q, kind), []) if 0 < float(r["bin_low"]) and float(r["bin_high"]) < float("inf")), key=lambda r: float(r["bin_low"]))
            if not data:
                continue
            centres = [(float(r["bin_low"]) * float(r["bin_high"])) ** 0.5 for r in data]
            rate = [float(r["events_per_second"]) for r in data]
            ax.step(centres, rate, style, where="mid", label=kind)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(q.replace("_", " ") + " per event [J]")
        ax.grid(True, which="both", alpha=0.3)
        if ax.get_lines():
            ax.legend(fontsize="small")
    axes[0].set_ylabel("events per second per bin")
    title = "Collision energy spectra (" + path + ")"
    if labels:
        title += "\nsize classes: " + ", ".join(labels[k] for k in sorted(labels))
    fig.suptitle(title)
    fig.tight_layout()
    out = path[:-4] + ".png" if path.endswith(".csv") else path + ".png"
    fig.savefig(out, dpi=110)
    print("wrote " + out)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: plot_spectra.py spectra.csv")
    main(sys.argv[1])
