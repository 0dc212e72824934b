#!/usr/bin/env python3
"""Plots the collision energy spectra a mill run wrote (spectra.csv) to spectra.png beside it:
events per second against energy, one panel per quantity (impact energy, normal and tangential
energy dissipated per contact event), ball-ball and ball-liner apart. Debian: python3-matplotlib."""
import csv
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(path):
    rows = defaultdict(list)
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            rows[(r["quantity"], r["kind"])].append(r)
    quantities = ["impact_energy", "normal_dissipated", "tangential_dissipated"]
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2), sharey=True)
    for ax, q in zip(axes, quantities):
        for kind, style in (("ball-ball", "-"), ("ball-liner", "--")):
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
        ax.legend()
    axes[0].set_ylabel("events per second per bin")
    fig.suptitle("Collision energy spectra (" + path + ")")
    fig.tight_layout()
    out = path[:-4] + ".png" if path.endswith(".csv") else path + ".png"
    fig.savefig(out, dpi=110)
    print("wrote " + out)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: plot_spectra.py spectra.csv")
    main(sys.argv[1])
