#!/usr/bin/python3
"""Free flight against dense contact: the report of bench_workloads, as tables and a plot.

Runs bench_workloads with --benchmark_format=json (or reads a saved JSON with --json) and writes to
docs/workloads/ (or --out):
  workloads.md    tables: cost per particle-step against N for both workloads, fixed against doubling,
                  Verlet and exact, 1 against 2 threads; cost per simulated step (fixed and doubling on
                  equal footing); time by stage; bytes and contacts per particle; hash checks
  workloads.png   cost per particle-step against N (one panel per workload) and the time by stage
  bench_workloads.json   the raw Google Benchmark output (when the binary was run)

Usage:
  bench/workloads.py [--binary build/bench/bench_workloads] [--out docs/workloads] [--filter REGEX]
  bench/workloads.py --json docs/workloads/bench_workloads.json      # re-plot a saved run
1e6 particles: DEM_BENCH_LARGE=1 bench/workloads.py (adds N = 1e6; minutes, ~1-2 GB).

Definitions (bench/bench_workloads.cpp):
  cost per particle-step  wall time of whole sync intervals / particle-steps, every trial and retry of
                          step doubling counted (World counters)
  cost per simulated dt   wall time / (N x simulated time / 7.27e-6 s): what one fixed step's worth of
                          simulated time costs per particle; fixed and doubling compare directly here
  stages                  per-call costs of the engine's stage functions (Verlet kernels) scaled by how
                          often an interval calls them: grid x pair rebuilds, contacts and forces x force
                          evaluations per particle, integrate x particle-steps; "other" is the interval's
                          time minus these (skin and finite-state checks; under doubling the islands,
                          trial bookkeeping, error estimates and redos). Doubling evaluates forces on
                          islands, not the whole system, so its stage split is an estimate.
"""
import argparse
import json
import os
import platform
import re
import subprocess
import sys

DT = 7.27e-6  # the workloads' fixed step [s]
NAME = re.compile(r"^(interval|stage)/(\w+)/(.+)/n:(\d+)/threads:(\d+)")
WORKLOADS = [("free", "free flight"), ("dense", "dense bed")]
STAGES = ["grid", "contacts", "forces", "integrate"]
UNIT_NS = {"ns": 1.0, "us": 1e3, "ms": 1e6, "s": 1e9}


def repo_root():
    return os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def find_binary(given):
    if given:
        return given
    root = repo_root()
    for build in ("build", "build-bw", "build-bench"):
        path = os.path.join(root, build, "bench", "bench_workloads")
        if os.path.exists(path):
            return path
    sys.exit("bench_workloads not found: build it (ninja -C build bench_workloads) or pass --binary")


def run_benchmarks(binary, out_json, bench_filter, repetitions):
    cmd = [binary, "--benchmark_format=json", "--benchmark_out=" + out_json, "--benchmark_out_format=json",
           f"--benchmark_repetitions={repetitions}", "--benchmark_report_aggregates_only=true"]
    if bench_filter:
        cmd.append("--benchmark_filter=" + bench_filter)
    print("running:", " ".join(cmd), file=sys.stderr)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)


def pick_runs(data):
    """One record per benchmark: the median aggregate when the run had repetitions, else the median
    (by time) of its iteration runs."""
    medians, runs = {}, {}
    for b in data["benchmarks"]:
        if b.get("error_occurred"):
            continue
        if b.get("run_type") == "aggregate":
            if b.get("aggregate_name") == "median":
                medians[b["run_name"] if "run_name" in b else b["name"].rsplit("_", 1)[0]] = b
        else:
            runs.setdefault(b.get("run_name", b["name"]), []).append(b)
    picked = dict(medians)
    for name, rs in runs.items():
        if name not in picked:
            picked[name] = sorted(rs, key=lambda b: b["real_time"])[len(rs) // 2]
    return picked


def parse(data):
    """Interval and stage records keyed by their name's parts."""
    intervals, stages = {}, {}
    for name, b in pick_runs(data).items():
        m = NAME.match(name)
        if not m:
            continue
        kind, workload, middle, n, threads = m.group(1), m.group(2), m.group(3), int(m.group(4)), int(m.group(5))
        it = re.search(r"/iterations:(\d+)", name)
        iterations = int(it.group(1)) if it else b["iterations"]  # per run (aggregates count repetitions)
        time_ns = b["real_time"] * UNIT_NS[b.get("time_unit", "ns")]  # per iteration
        rec = dict(b, time_ns=time_ns, hash=b.get("label", "").replace("hash=", ""))
        if kind == "interval":
            control, method = middle.split("/")
            per_interval = time_ns * iterations / b["intervals"]  # [ns]
            rec["ns_per_step"] = 1e9 / b["particle_steps_per_s"] if b["particle_steps_per_s"] > 0 else float("nan")
            rec["ns_per_interval_particle"] = per_interval / n
            rec["ns_per_sim_dt"] = per_interval / n / (b["sim_time_per_interval"] / DT)
            intervals[(workload, control, method, n, threads)] = rec
        else:
            rec["ns_per_particle"] = time_ns / n
            stages[(workload, middle, n, threads)] = rec
    return intervals, stages


def stage_split(intervals, stages, workload, control, n, threads):
    """Per particle-step [ns]: each stage and `other`, or None if something is missing."""
    rec = intervals.get((workload, control, "verlet", n, threads))
    if rec is None or any((workload, s, n, threads) not in stages for s in STAGES):
        return None
    per = {s: stages[(workload, s, n, threads)]["ns_per_particle"] for s in STAGES}
    calls = {"grid": rec["rebuilds_per_interval"],  # each rebuild covers all N particles
             "contacts": rec["force_evals_per_interval"], "forces": rec["force_evals_per_interval"],
             "integrate": rec["steps_per_interval"]}
    steps = rec["steps_per_interval"]
    split = {s: per[s] * calls[s] / steps for s in STAGES}
    split["other"] = rec["ns_per_interval_particle"] / steps - sum(split.values())
    split["total"] = rec["ns_per_interval_particle"] / steps
    return split


def fmt(x, digits=3):
    if x is None or x != x:
        return "–"
    if abs(x) >= 100:
        return f"{x:,.0f}"
    return f"{x:.{digits}g}"


def machine(context):
    model = "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    load = context.get("load_avg", [])
    load_text = ", ".join(f"{x:.1f}" for x in load) if load else "n/a"
    return (f"{context.get('num_cpus', '?')}-core {platform.machine()} ({model}), Release build, "
            f"{context.get('date', '')}; the machine is shared and noisy (load average at the start "
            f"{load_text}), so take single figures to about ±20% and compare ratios within one run")


def write_markdown(path, data, intervals, stages):
    sizes = sorted({k[3] for k in intervals})
    cases = [(c, m) for c in ("fixed", "doubling") for m in ("verlet", "exact")]
    lines = ["# Free flight against dense contact", "",
             f"Machine: {machine(data.get('context', {}))}.", "",
             "Generated by `bench/workloads.py` from `bench_workloads` (bench/bench_workloads.cpp); "
             "doubling: dt_base = 7.27e-6 s, level_max = 3 (8 dt per sync interval), tolerance 1e-2; "
             "exact: friction zeroed. Small N: a corner block of the shipped 20,000-particle bed or gas; "
             "large N: copies of the block side by side.", ""]

    def grid_table(title, key, note):
        lines.extend([f"## {title}", "", note, ""])
        head = "| workload | control | method | " + " | ".join(f"N={n:,} 1T | 2T" for n in sizes) + " |"
        lines.append(head)
        lines.append("|" + "---|" * (3 + 2 * len(sizes)))
        for w, wname in WORKLOADS:
            for c, m in cases:
                cells = []
                for n in sizes:
                    for t in (1, 2):
                        rec = intervals.get((w, c, m, n, t))
                        cells.append(fmt(rec[key]) if rec else "–")
                lines.append(f"| {wname} | {c} | {m} | " + " | ".join(cells) + " |")
        lines.append("")

    grid_table("Cost per particle-step [ns]", "ns_per_step",
               "Wall time of whole sync intervals over particle-steps (doubling: every trial and retry "
               "counted). 1T, 2T: threads.")
    grid_table("Cost per particle per 7.27 µs of simulated time [ns]", "ns_per_sim_dt",
               "Fixed and doubling on equal footing: what advancing one particle by one fixed step's "
               "worth of time costs.")

    lines.extend(["## Ratios", "", "| workload | N | 2T/1T speed-up, fixed Verlet | 2T/1T, doubling Verlet | "
                  "doubling/fixed cost per simulated dt (Verlet, 2T) | exact/Verlet cost per step (fixed, 2T) |",
                  "|---|---|---|---|---|---|"])
    for w, wname in WORKLOADS:
        for n in sizes:
            def get(c, m, t, key):
                rec = intervals.get((w, c, m, n, t))
                return rec[key] if rec else None

            def ratio(a, b):
                return None if a is None or b is None or b == 0 else a / b
            lines.append(f"| {wname} | {n:,} | {fmt(ratio(get('fixed', 'verlet', 1, 'ns_per_step'), get('fixed', 'verlet', 2, 'ns_per_step')))} | "
                         f"{fmt(ratio(get('doubling', 'verlet', 1, 'ns_per_step'), get('doubling', 'verlet', 2, 'ns_per_step')))} | "
                         f"{fmt(ratio(get('doubling', 'verlet', 2, 'ns_per_sim_dt'), get('fixed', 'verlet', 2, 'ns_per_sim_dt')))} | "
                         f"{fmt(ratio(get('fixed', 'exact', 2, 'ns_per_step'), get('fixed', 'verlet', 2, 'ns_per_step')))} |")
    lines.append("")

    lines.extend(["## Time by stage, Verlet [ns per particle-step]", "",
                  "Stage functions timed alone (grid = `GridBroadphase::find_pairs`; contacts = "
                  "`update_pair_contacts` + `build_pair_adjacency` + `update_wall_contacts`; forces = the law's "
                  "pair and wall loops + `gather_forces`; integrate = kick, drift, kick), times how often an "
                  "interval calls them; other = the interval minus the stages (checks; under doubling the "
                  "islands, trials' bookkeeping, error estimates, redos: the scheduler's overhead). These are "
                  "the stages of the compact contact list, which step doubling's islands use; a fixed-step "
                  "interval keeps its pair contacts in a persistent list instead (engine/neighbour_contacts.h: "
                  "no contact update between candidate rebuilds), so on the bed its interval costs less than "
                  "these stages and its 'other' is negative.", "",
                  "| workload | N | control | threads | grid | contacts | forces | integrate | other | total |",
                  "|---|---|---|---|---|---|---|---|---|---|"])
    for w, wname in WORKLOADS:
        for n in sizes:
            for c in ("fixed", "doubling"):
                for t in (1, 2):
                    s = stage_split(intervals, stages, w, c, n, t)
                    if s:
                        lines.append(f"| {wname} | {n:,} | {c} | {t} | " +
                                     " | ".join(fmt(s[k]) for k in STAGES + ["other", "total"]) + " |")
    lines.append("")

    lines.extend(["## Memory, contacts, determinism", "",
                  "Bytes per particle from `World::memory_bytes()` (capacities, scratch included) after the fixed "
                  "Verlet run; contacts per particle at its end; hashes: cases whose state hash is equal for 1 and "
                  "2 threads, out of those run with both.", "",
                  "| workload | N | bytes/particle | contacts/particle | contacts/s (fixed Verlet, 2T) | hashes equal 1T = 2T |",
                  "|---|---|---|---|---|---|"])
    for w, wname in WORKLOADS:
        for n in sizes:
            rec = intervals.get((w, "fixed", "verlet", n, 2)) or intervals.get((w, "fixed", "verlet", n, 1))
            equal = total = 0
            for c, m in cases:
                a, b = intervals.get((w, c, m, n, 1)), intervals.get((w, c, m, n, 2))
                if a and b:
                    total += 1
                    equal += a["hash"] == b["hash"]
            if rec:
                lines.append(f"| {wname} | {n:,} | {fmt(rec['bytes_per_particle'])} | {fmt(rec['contacts'] / n)} | "
                             f"{fmt(rec['contacts_per_s'] / 1e6)} M | {equal}/{total} |")
    lines.append("")
    with open(path, "w") as f:
        f.write("\n".join(lines))


def plot(path, intervals, stages):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sizes = sorted({k[3] for k in intervals})
    fig, axes = plt.subplots(2, 2, figsize=(13, 9.5))
    colours = {("fixed", "verlet"): "tab:blue", ("doubling", "verlet"): "tab:orange",
               ("fixed", "exact"): "tab:green", ("doubling", "exact"): "tab:red"}
    for col, (w, wname) in enumerate(WORKLOADS):
        ax = axes[0][col]
        for (c, m), colour in colours.items():
            for t, style in ((1, "-"), (2, "--")):
                pts = [(n, intervals[(w, c, m, n, t)]["ns_per_step"]) for n in sizes if (w, c, m, n, t) in intervals]
                if pts:
                    ax.plot([p[0] for p in pts], [p[1] for p in pts], style, marker="o", color=colour,
                            label=f"{c} {m}, {t} thread{'s' if t > 1 else ''}")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("N (particles)")
        ax.set_ylabel("wall time per particle-step [ns]")
        ax.set_title(f"{wname}: cost per particle-step")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)

        ax = axes[1][col]
        labels, bottoms = [], []
        bars = {k: [] for k in STAGES + ["other"]}
        for n in sizes:
            for c in ("fixed", "doubling"):
                for t in (1, 2):
                    s = stage_split(intervals, stages, w, c, n, t)
                    if not s:
                        continue
                    labels.append(f"{n:.0e}\n{c[:3]} {t}T")
                    for k in bars:
                        bars[k].append(s[k])
        x = list(range(len(labels)))
        bottoms = [0.0] * len(labels)
        stage_colours = {"grid": "tab:purple", "contacts": "tab:cyan", "forces": "tab:blue",
                         "integrate": "tab:olive", "other": "tab:gray"}
        for k in STAGES + ["other"]:  # a negative "other" (stages timed alone ran slower: noise) shows as 0
            heights = [max(v, 0) for v in bars[k]]
            ax.bar(x, heights, bottom=bottoms, color=stage_colours[k], label=k)
            bottoms = [b + v for b, v in zip(bottoms, heights)]
        totals = [sum(bars[k][i] for k in bars) for i in range(len(labels))]
        ax.plot(x, totals, "k_", markersize=14, mew=2, label="whole interval")
        ax.set_xticks(x)
        ax.set_xticklabels(labels, fontsize=7)
        ax.set_ylabel("ns per particle-step (Verlet)")
        ax.set_title(f"{wname}: time by stage (fix = fixed, dou = doubling)")
        ax.legend(fontsize=7)
        ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--binary", help="bench_workloads executable (default: build*/bench/bench_workloads)")
    parser.add_argument("--json", help="read this Google Benchmark JSON instead of running the binary")
    parser.add_argument("--out", default=os.path.join(repo_root(), "docs", "workloads"))
    parser.add_argument("--filter", help="--benchmark_filter passed to the binary")
    parser.add_argument("--repetitions", type=int, default=3,
                        help="runs of each benchmark; the report takes the median (default 3)")
    parser.add_argument("--no-plot", action="store_true")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    source = args.json
    if not source:
        source = os.path.join(args.out, "bench_workloads.json")
        run_benchmarks(find_binary(args.binary), source, args.filter, args.repetitions)
    with open(source) as f:
        data = json.load(f)
    intervals, stages = parse(data)
    if not intervals:
        sys.exit(f"{source}: no interval/... benchmarks in it")
    write_markdown(os.path.join(args.out, "workloads.md"), data, intervals, stages)
    print("wrote", os.path.join(args.out, "workloads.md"))
    if not args.no_plot:
        try:
            plot(os.path.join(args.out, "workloads.png"), intervals, stages)
            print("wrote", os.path.join(args.out, "workloads.png"))
        except ImportError:
            sys.exit("matplotlib missing: apt-get install python3-matplotlib (or use --no-plot)")


if __name__ == "__main__":
    main()
