#!/usr/bin/env python3
"""mill_power.py: the power draw of a mill per revolution, from Python, plotted to a PNG.

Loads a mill scene through the dem module, runs it with a callback at every sync time that feeds
dem.MillMonitor (the monitor `dem run` uses: the same per-revolution figures and the same
mean_power_draw, to the bit), and draws the power draw of each revolution, the start-up ones
marked, with the mean over the steady revolutions.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/mill_power.py scenes/mill_2d.toml --until 3.5

Usage: mill_power.py [scene.toml] [--until T] [--set key.path=value ...] [--png power.png]
"""
import argparse
import math

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt  # noqa: E402

import dem  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", nargs="?", default="scenes/mill_2d.toml")
    parser.add_argument("--until", type=float, help="end time [s] (default: the scene's [run] until)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a scene value by dotted path")
    parser.add_argument("--png", default="mill_power.png", help="the plot to write")
    args = parser.parse_args()

    world = dem.World.from_scene(args.scene, overrides=args.set)
    if not world.has_mill:
        parser.error(f"no [mill] section in {args.scene}")
    until = args.until if args.until is not None else world.scene_until
    monitor = dem.MillMonitor(world)
    print("# revolution  end_time[s]  power_draw[W]  steady")

    def on_sync(w):
        for r in monitor.observe(w):
            print(f"{r['index']:12d}  {r['end']:11.6f}  {r['power_draw']:13.6g}  {'yes' if r['steady'] else 'no'}")

    world.run_until(until, on_sync)
    revolutions = monitor.revolutions
    mean = monitor.mean_power_draw
    if mean is not None:
        print(f"mean_power_draw {mean!r}")
    else:
        print(f"# no steady revolution by t = {world.time:g} s")

    fig, ax = plt.subplots(figsize=(6, 4))
    index = [r["index"] for r in revolutions]
    power = [r["power_draw"] for r in revolutions]
    colours = ["tab:blue" if r["steady"] else "tab:gray" for r in revolutions]
    ax.bar(index, power, color=colours)
    if mean is not None and math.isfinite(mean):
        ax.axhline(mean, color="tab:red", linestyle="--", label=f"mean over steady revolutions: {mean:.4g} W")
        ax.legend()
    ax.set_xlabel("revolution (grey: start-up, not in the mean)")
    ax.set_ylabel("power draw [W]")
    ax.set_title(f"{world.scene_name}: power draw per revolution")
    if index:
        ax.set_xticks(index)
    fig.tight_layout()
    fig.savefig(args.png, dpi=100)
    print(f"# wrote {args.png}")


if __name__ == "__main__":
    main()
