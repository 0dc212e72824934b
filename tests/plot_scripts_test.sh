#!/bin/sh
# Every plotting script draws a PNG from a small input, with Debian's /usr/bin/python3 and its
# python3-matplotlib (scripts/install_deps.sh installs it): `dem run` draws spectra.png through
# bench/plot_spectra.py, `dem trade` draws trade.png through bench/plot_trade.py, bench/workloads.py
# re-plots the committed benchmark JSON, and bench/seed_experiment.py runs its experiment.
# Usage: plot_scripts_test.sh <build dir> <source dir>
set -eu
build=$1
src=$2
dem=$build/engine/dem
work=$(mktemp -d "${TMPDIR:-/tmp}/dem_plot_test.XXXXXX")
trap 'rm -rf "$work"' EXIT
fail() { echo "plot_scripts_test: $*" >&2; exit 1; }
/usr/bin/python3 -c "import matplotlib" 2>/dev/null ||
  fail "/usr/bin/python3 cannot import matplotlib: apt-get install python3-matplotlib (scripts/install_deps.sh does)"
# A PNG file: its 8-byte signature, and more than a header.
is_png() {
  [ -f "$1" ] && [ "$(head -c 8 "$1" | od -An -tx1 | tr -d ' \n')" = "89504e470d0a1a0a" ] && [ "$(wc -c < "$1")" -gt 1000 ]
}

"$dem" run "$src/scenes/mill_2d.toml" --until 0.2 --quiet --out "$work/mill" > "$work/mill.log" 2>&1 ||
  { cat "$work/mill.log"; fail "dem run of the mill failed"; }
is_png "$work/mill/spectra.png" || { cat "$work/mill.log"; fail "dem run drew no spectra.png"; }

"$dem" trade "$src/scenes/seed_slope.toml" --fixed 0.01,0.005 --tol 1e-2 --until 1 --quiet --out "$work/trade" \
  > "$work/trade.log" 2>&1 || { cat "$work/trade.log"; fail "dem trade failed"; }
is_png "$work/trade/trade.png" || { cat "$work/trade.log"; fail "dem trade drew no trade.png"; }

/usr/bin/python3 "$src/bench/workloads.py" --json "$src/docs/workloads/bench_workloads.json" --out "$work/workloads" \
  > "$work/workloads.log" 2>&1 || { cat "$work/workloads.log"; fail "bench/workloads.py failed"; }
is_png "$work/workloads/workloads.png" || fail "bench/workloads.py drew no workloads.png"

/usr/bin/python3 "$src/bench/seed_experiment.py" --dem "$dem" --out "$work/seed" > "$work/seed.log" 2>&1 ||
  { cat "$work/seed.log"; fail "bench/seed_experiment.py failed"; }
for f in seed_trajectory.png seed_error.png; do
  is_png "$work/seed/$f" || fail "bench/seed_experiment.py drew no $f"
done
echo "plot_scripts_test: ok"
