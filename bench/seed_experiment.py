#!/usr/bin/python3
"""The seed paper's experiment (Zhang & Whiten 2001; docs/physics.md 8.8), reproduced with `dem`.

Runs the seed slope (scenes/seed_slope.toml) with fixed steps of 0.1, 0.01 and 0.001 s and with step
doubling at a few tolerances, for each stepper that handles the scene, against a converged reference
(a fixed step of 1e-5 s, checked against 2e-5 s) and the docs/physics.md 8.8 oracle. Every run
writes its rows at the same times (every 0.1 s), where errors and events are read for all. Writes
seed_experiment.md (the table, the cost at equal accuracy and the paper's timings beside ours) and
two plots like the paper's figures 1 and 2 (the path; error against time) into the output folder.

usage: bench/seed_experiment.py [--dem build/engine/dem] [--out docs/seed_experiment] [--work DIR]
Needs Debian's python3-matplotlib for the plots (apt-get install python3-matplotlib).
"""
import argparse
import bisect
import csv
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENE = os.path.join(ROOT, "scenes", "seed_slope.toml")
# docs/physics.md 8.8, sphere, standard rolling mode: rolling at t, v, s; stop t, stop s.
ORACLE = {"roll_t": 0.84869, "roll_v": 5.9222, "roll_s": 6.7565, "stop_t": 5.1040, "stop_s": 19.357}
MASS, RADIUS, KAPPA, DELTA0 = 4.0, 1.0, 0.4, 0.019219
UNTIL = 8.0
ROW_INTERVAL = 0.1
FIXED_STEPS = (0.1, 0.01, 0.001)
TOLERANCES = (0.3, 0.1, 1e-2, 1e-3, 1e-4)
# The paper's table (its table-driven stepper): seconds to construct the table, seconds to calculate.
PAPER_TIMINGS = {"dt = 0.1": (1.8, 1.5), "dt = 0.01": (1.8, 14.3), "dt = 0.001": (1.8, 153.2), "variable": (2.0, 11.9)}


def run(dem, out, settings):
    args = [dem, "run", SCENE, "--quiet", "--out", out, "--until", str(UNTIL),
            "--set", "output.trajectories=true", "--set", "output.snapshot_interval=0"]
    for key, value in settings.items():
        args += ["--set", f"{key}={value}"]
    shutil.rmtree(out, ignore_errors=True)  # a failed run must not leave an earlier run's rows behind
    done = subprocess.run(args, capture_output=True, text=True)
    rows = []
    rows_path = os.path.join(out, "trajectories.csv")
    if os.path.exists(rows_path):
        with open(rows_path) as f:
            for r in csv.DictReader(f):
                try:
                    rows.append({k: float(v) for k, v in r.items()})
                except (TypeError, ValueError):  # a row cut short where the run stopped
                    break
    if done.returncode != 0:
        why = done.stderr.strip().splitlines()[-1] if done.stderr.strip() else f"exit {done.returncode}"
        return {"summary": None, "rows": rows, "failure": why}, why
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    return {"summary": summary, "rows": rows}, None


def along_slope(row):
    """Distance down the slope: the scene's slope is the plane z = 0 with gravity tilted to +x."""
    return row["x"]


def trajectory_error(rows, reference):
    """Largest |x - x_ref| over the run's rows, the reference interpolated linearly in time."""
    times = [r["time"] for r in reference]
    worst, series = 0.0, []
    for r in rows:
        k = min(max(bisect.bisect_left(times, r["time"]), 1), len(times) - 1)
        a, b = reference[k - 1], reference[k]
        u = 0.0 if b["time"] == a["time"] else (r["time"] - a["time"]) / (b["time"] - a["time"])
        e = math.sqrt(sum((r[c] - (a[c] + u * (b[c] - a[c]))) ** 2 for c in ("x", "y", "z")))
        worst = max(worst, e)
        series.append((r["time"], e))
    return worst, series


def events(rows):
    """Rolling (v = omega a) and stop (v < 1e-3 v0) from the rows, interpolated between rows."""
    lever = RADIUS - DELTA0 / 2
    found = {}
    for a, b in zip(rows, rows[1:]):
        f0, f1 = a["vx"] - abs(a["wy"]) * lever, b["vx"] - abs(b["wy"]) * lever
        if "roll_t" not in found and f0 > 0 >= f1:
            u = f0 / (f0 - f1)
            found["roll_t"] = a["time"] + u * (b["time"] - a["time"])
            found["roll_v"] = a["vx"] + u * (b["vx"] - a["vx"])
            found["roll_s"] = along_slope(a) + u * (along_slope(b) - along_slope(a))
        v_stop = 1e-3 * rows[0]["vx"]
        if "stop_t" not in found and a["vx"] >= v_stop > b["vx"]:
            u = (a["vx"] - v_stop) / (a["vx"] - b["vx"])
            found["stop_t"] = a["time"] + u * (b["time"] - a["time"])
            found["stop_s"] = along_slope(a) + u * (along_slope(b) - along_slope(a))
    return found


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dem", default=os.path.join(ROOT, "build", "engine", "dem"))
    parser.add_argument("--out", default=os.path.join(ROOT, "docs", "seed_experiment"))
    parser.add_argument("--work", default=None, help="folder for the runs' outputs (default: a temporary one)")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    work = args.work or tempfile.mkdtemp(prefix="seed_runs_")
    os.makedirs(work, exist_ok=True)

    # Every run writes its rows at the same times, the doubling runs' sync times, so that errors and
    # event times are read off the same instants for all (rows never cap a doubling run's steps).
    rows = {"output.interval": ROW_INTERVAL}
    reference, error = run(args.dem, os.path.join(work, "reference"), {"integrator.dt": 1e-5, **rows})
    if error is not None:
        sys.exit(f"reference run failed: {error}")
    check, error = run(args.dem, os.path.join(work, "reference_check"), {"integrator.dt": 2e-5, **rows})
    if error is not None:
        sys.exit(f"reference check run failed: {error}")
    reference_error, _ = trajectory_error(check["rows"], reference["rows"])

    settings = []
    for method in ("verlet", "exact"):
        for dt in FIXED_STEPS:
            settings.append((method, "fixed", f"dt = {dt:g}", {"integrator.method": method, "integrator.dt": dt, **rows}))
        for tol in TOLERANCES:
            # Steps from 0.1 s down to 0.1 * 2^-14 s; sync intervals of 0.1 s.
            settings.append((method, "doubling", f"tol = {tol:g}",
                             {"integrator.method": method, "integrator.control": "doubling", "integrator.dt": 0.1,
                              "integrator.tolerance": tol, "integrator.level_min": -14, "integrator.level_max": 0,
                              **rows}))
    results = []
    for method, control, label, setting in settings:
        name = f"{method}_{control}_{label.split('= ')[1]}"
        result, error = run(args.dem, os.path.join(work, name), setting)
        if error is None:
            worst, series = trajectory_error(result["rows"], reference["rows"])
            result["error"], result["series"], result["events"] = worst, series, events(result["rows"])
        results.append((method, control, label, result, error))

    lines = ["| stepper | control | setting | wall time [s] | particle-steps | force evaluations | "
             "max trajectory error [m] | rolling at t | stop t | stop s |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for method, control, label, r, error in results:
        if error is not None:
            short = error.split(". ")[0].replace("dem: ", "")
            short = short.split(": ")[-1] if "error:" in short else short
            lines.append(f"| {method} | {control} | {label} | {short} | | | | | | |")
            continue
        c, ev = r["summary"]["counters"], r["events"]

        def rel(key):
            return f"{ev[key]:.4g} ({100 * (ev[key] - ORACLE[key]) / ORACLE[key]:+.2f}%)" if key in ev else "none"
        lines.append(f"| {method} | {control} | {label} | {r['summary']['wall_time']:.3g} | {c['particle_steps']} | "
                     f"{c['force_evaluations']} | {r['error']:.3g} | {rel('roll_t')} | {rel('stop_t')} | "
                     f"{rel('stop_s')} |")
    table = "\n".join(lines)
    text = ("Seed slope (docs/physics.md 8.8, sphere, standard rolling mode), 8 s simulated. Oracle: rolling at "
            f"t = {ORACLE['roll_t']} s, stop at t = {ORACLE['stop_t']} s, s = {ORACLE['stop_s']} m. "
            f"Reference: Verlet at a fixed dt = 1e-5 s (its difference from 2e-5 s, {reference_error:.2g} m, bounds "
            f"what the table can resolve). Every run writes its rows every {ROW_INTERVAL:g} s (the doubling runs' "
            "sync interval); errors are sampled and event times interpolated at those rows for all.\n\n"
            + table + "\n\n" + equal_accuracy(results) + "\n\n" + paper_timings(results) + "\n")
    with open(os.path.join(args.out, "seed_experiment.md"), "w") as f:
        f.write(text)
    print(text)
    plot(args.out, reference, results)


def find(results, method, label):
    for m, _, l, r, error in results:
        if m == method and l == label and error is None:
            return r
    return None


def equal_accuracy(results):
    """Verlet: the doubling's cost at the fixed step's accuracy, and the fixed step's at the doubling's."""
    fixed = find(results, "verlet", "dt = 0.01")
    if fixed is None:
        return "Verlet at dt = 0.01 failed: no comparison at equal accuracy."
    target, cost = fixed["error"], fixed["summary"]["counters"]["particle_steps"]
    out = [f"**At equal accuracy (Verlet).** Fixed dt = 0.01: {cost} particle-steps for an error of {target:.3g} m."]
    for low, high, scope in ((1e-4, 1e-1, "over tolerances 1e-1 to 1e-4"), (0, float("inf"), "over every tolerance")):
        rows = [(r["summary"]["counters"]["particle_steps"], tol, r["error"])
                for tol in TOLERANCES if low <= tol <= high
                for r in [find(results, "verlet", f"tol = {tol:g}")] if r is not None and r["error"] <= target]
        if rows:
            steps, tol, err = min(rows)
            out.append(f"The cheapest doubling run at least as accurate, {scope}: tol = {tol:g}, {steps} "
                       f"particle-steps ({steps / cost:.2f} times) for an error of {err:.3g} m.")
        else:
            out.append(f"No doubling run {scope} is as accurate.")
    # The fixed step's error is about proportional to dt here (its first steps misjudge the friction's
    # ramp): the step that would match a doubling run's error, from the two finer fixed steps.
    fine = find(results, "verlet", "dt = 0.001")
    loose = find(results, "verlet", f"tol = {TOLERANCES[0]:g}")
    if fine is not None and loose is not None and 0 < fine["error"] < target and loose["error"] > 0:
        order = math.log(target / fine["error"]) / math.log(0.01 / 0.001)
        dt = 0.001 * (loose["error"] / fine["error"]) ** (1 / order)
        out.append(f"The other way round: the fixed step's error falls as dt^{order:.2f} between dt = 0.01 and 0.001, "
                   f"so matching tol = {TOLERANCES[0]:g}'s {loose['error']:.3g} m would take dt = {dt:.2g}, about "
                   f"{UNTIL / dt:.0f} particle-steps ({UNTIL / dt / loose['summary']['counters']['particle_steps']:.1f} "
                   "times the doubling's).")
    return " ".join(out)


def paper_timings(results):
    """The paper's timings (its table-driven stepper: table, then calculation) beside this engine's."""
    lines = ["The paper's timings (Zhang & Whiten 2001, table-driven stepper; seconds on its machine) beside "
             "this engine's (wall seconds on this machine, particle-steps in brackets). Machines differ by decades, "
             "so compare each column against its dt = 0.01 row. The exact stepper builds its coefficient table "
             "on first use, inside the run (one class here), so its table time is part of its wall time.", "",
             "| setting | paper: table [s] | paper: calculation [s] | paper: / dt = 0.01 | exact stepper | "
             "Verlet | Verlet: steps / dt = 0.01 |", "|---|---|---|---|---|---|---|"]
    base = find(results, "verlet", "dt = 0.01")
    for label, (table_s, calc_s) in PAPER_TIMINGS.items():
        ours = [label] if label != "variable" else [f"tol = {t:g}" for t in (1e-1, 1e-2)]
        for mine in ours:
            cells = []
            for method in ("exact", "verlet"):
                r = find(results, method, mine)
                cells.append("failed" if r is None else
                             f"{r['summary']['wall_time']:.2g} s ({r['summary']['counters']['particle_steps']})")
            v = find(results, "verlet", mine)
            ratio = (f"{v['summary']['counters']['particle_steps'] / base['summary']['counters']['particle_steps']:.2f}"
                     if v is not None and base is not None else "")
            name = label if label != "variable" else f"variable (paper); doubling, {mine}"
            lines.append(f"| {name} | {table_s} | {calc_s} | {calc_s / PAPER_TIMINGS['dt = 0.01'][1]:.2f} | "
                         f"{cells[0]} | {cells[1]} | {ratio} |")
    return "\n".join(lines)


def plot(out, reference, results):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("python3-matplotlib is not installed: no plots", file=sys.stderr)
        return
    # Figure 1 as the paper draws it: the path, with what the coarse fixed step does to it.
    fig, (path, along) = plt.subplots(1, 2, figsize=(11, 4.5))
    ref = reference["rows"]
    path.plot([along_slope(r) for r in ref], [r["z"] for r in ref], "k-", lw=2.5, alpha=0.3, label="reference (dt = 1e-5)")
    along.plot([r["time"] for r in ref], [along_slope(r) for r in ref], "k-", lw=2.5, alpha=0.3,
               label="reference (dt = 1e-5)")
    for m, _, label, r, error in results:
        if m != "verlet" or label not in ("dt = 0.1", "dt = 0.01", "tol = 0.01") or not r["rows"]:
            continue
        name = f"{m}, {label}" + (" (diverged)" if error is not None else "")
        path.plot([along_slope(x) for x in r["rows"]], [x["z"] for x in r["rows"]], ".-", ms=3, lw=1, label=name)
        along.plot([x["time"] for x in r["rows"]], [along_slope(x) for x in r["rows"]], ".-", ms=3, lw=1, label=name)
    path.set_xlabel("distance down the slope [m]")
    path.set_ylabel("height of the centre above the slope [m]")
    path.set_title("Seed slope: the path (cf. Zhang & Whiten 2001, Fig. 1)")
    path.legend(fontsize=8)
    along.set_xlabel("time [s]")
    along.set_ylabel("distance down the slope [m]")
    along.set_title("the same runs against time")
    along.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "seed_trajectory.png"), dpi=110)
    # Figure 2 as the paper draws it (linear axis): the error of the fixed step and the variable one.
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for m, _, label, r, error in results:
        if error is None and label in ("dt = 0.01", "tol = 0.1", "tol = 0.01"):
            ax.plot([t for t, _ in r["series"]], [e for _, e in r["series"]], ".-" if m == "verlet" else "x--",
                    ms=3, lw=1, label=f"{m}, {label}")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("|x - x_reference| [m]")
    ax.set_title("Seed slope: trajectory error (cf. Zhang & Whiten 2001, Fig. 2)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "seed_error.png"), dpi=110)


if __name__ == "__main__":
    main()
