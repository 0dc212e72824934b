#!/usr/bin/env bash
# The dense bed (scenes/dense_bed.toml) on LIGGGHTS 3.8 and on this engine, both on 2 cores, the same
# number of steps from the same particles, interleaved so both see the same machine. Prints each run's
# particle-steps per second and the ratio. Needs a Release build in build/ and the Debian package
# liggghts (apt-get install liggghts, which brings Open MPI).
# Usage: bench/liggghts/compare.sh [STEPS (default 4000)] [ROUNDS (default 3)]
set -euo pipefail
cd "$(dirname "$0")/../.."
steps=${1:-4000}
rounds=${2:-3}
dt=7.27e-6
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
command -v liggghts >/dev/null || { echo "liggghts not found: apt-get install liggghts" >&2; exit 2; }
[ -x build/engine/dem ] || { echo "build/engine/dem not found: build Release in build/ first" >&2; exit 2; }
python3 bench/liggghts/csv_to_data.py scenes/data/dense_bed_settled.csv "$work/bed.data"
mpi=(mpirun -np 2)
[ "$(id -u)" = 0 ] && mpi+=(--allow-run-as-root)
until=$(python3 -c "print($steps * $dt)")
for round in $(seq "$rounds"); do
  # LIGGGHTS: 'Loop time' covers the time steps only (no setup, no output).
  (cd "$work" && "${mpi[@]}" liggghts -in "$OLDPWD/bench/liggghts/dense_bed.in" -var data bed.data \
    -var steps "$steps" -log liggghts.log -screen none)
  loop=$(sed -n 's/^Loop time of \([0-9.e+-]*\) on 2 procs.*/\1/p' "$work/liggghts.log")
  # This engine: wall_time in summary.json covers the sync intervals and the rows written at output
  # times; no snapshot in between (snapshot_interval beyond the run).
  build/engine/dem run scenes/dense_bed.toml --threads 2 --until "$until" --quiet --out "$work/dem" \
    --set output.snapshot_interval=1 --set output.interval=1
  python3 - "$steps" "$loop" "$work/dem/summary.json" "$round" <<'PY'
import json
import sys
steps, loop, summary, round_ = int(sys.argv[1]), float(sys.argv[2]), json.load(open(sys.argv[3])), sys.argv[4]
n = 20000
ours, our_steps = summary["wall_time"], summary["counters"]["sync_intervals"]  # a run ends at the first step at or after --until
liggghts_rate, dem_rate = n * steps / loop, n * our_steps / ours
print(f"round {round_}: 20,000 spheres on 2 cores: LIGGGHTS {liggghts_rate / 1e6:.2f} M particle-steps/s ({steps} steps, "
      f"{loop:.2f} s), dem {dem_rate / 1e6:.2f} M ({our_steps} steps, {ours:.2f} s): dem / LIGGGHTS = {dem_rate / liggghts_rate:.2f}")
PY
done
