#!/usr/bin/env bash
# The dense bed (scenes/dense_bed.toml) on LIGGGHTS 3.8, on LAMMPS (gran/hooke/history) and on this
# engine, each on 2 cores (2 MPI processes, 2 threads), the same steps from the same particles, the
# three interleaved in every round so all see the same machine. Prints each run's particle-steps per
# second, then the median of each over the rounds and the ratio of dem's median to the fastest peer's.
# Nothing is written inside the timed windows: LIGGGHTS' and LAMMPS' "Loop time" covers the steps
# only (thermo output every 1,000 steps aside), dem's wall_time the steps (outputs and snapshots
# beyond the run).
# Needs a Release build in build/ and the Debian packages liggghts and lammps (with Open MPI):
#   apt-get install liggghts lammps
# Usage: bench/peers/compare.sh [STEPS (default 4000)] [ROUNDS (default 5)] [THREADS (default 2)]
set -euo pipefail
cd "$(dirname "$0")/../.."
steps=${1:-4000}
rounds=${2:-5}
cores=${3:-2}
dt=7.27e-6
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
command -v liggghts >/dev/null || { echo "liggghts not found: apt-get install liggghts" >&2; exit 2; }
command -v lmp >/dev/null || { echo "lmp not found: apt-get install lammps" >&2; exit 2; }
[ -x build/engine/dem ] || { echo "build/engine/dem not found: build Release in build/ first" >&2; exit 2; }
python3 bench/peers/csv_to_data.py scenes/data/dense_bed_settled.csv "$work/bed.data"
mpi=(mpirun -np "$cores")
[ "$(id -u)" = 0 ] && mpi+=(--allow-run-as-root)
until=$(python3 -c "print(($steps - 0.5) * $dt)")
rates=$work/rates.txt
: > "$rates"
loop_time() { sed -n "s/^Loop time of \([0-9.e+-]*\) on $cores procs.*/\1/p" "$1"; }
for round in $(seq "$rounds"); do
  (cd "$work" && "${mpi[@]}" liggghts -in "$OLDPWD/bench/peers/dense_bed_liggghts.in" -var data bed.data \
    -var steps "$steps" -log liggghts.log -screen none)
  (cd "$work" && "${mpi[@]}" lmp -in "$OLDPWD/bench/peers/dense_bed_lammps.in" -var data bed.data \
    -var steps "$steps" -log lammps.log -screen none)
  build/engine/dem run scenes/dense_bed.toml --threads "$cores" --until "$until" --quiet --out "$work/dem" \
    --set output.snapshot_interval=1 --set output.interval=1
  python3 - "$steps" "$(loop_time "$work/liggghts.log")" "$(loop_time "$work/lammps.log")" "$work/dem/summary.json" \
    "$round" >> "$rates" <<'PY'
import json
import sys
steps, liggghts, lammps, summary, round_ = int(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3]), json.load(open(sys.argv[4])), sys.argv[5]
n = 20000
dem = n * summary["counters"]["sync_intervals"] / summary["wall_time"]
print(round_, n * steps / liggghts, n * steps / lammps, dem)
PY
  tail -n 1 "$rates" | awk '{printf "round %d: LIGGGHTS %.2f M particle-steps/s, LAMMPS %.2f M, dem %.2f M: dem / fastest peer %.2f\n", $1, $2/1e6, $3/1e6, $4/1e6, $4/($2>$3?$2:$3)}'
done
python3 - "$rates" "$steps" "$cores" <<'PY'
import statistics
import sys
rows = [list(map(float, line.split())) for line in open(sys.argv[1])]
med = [statistics.median(r[c] for r in rows) for c in (1, 2, 3)]
print(f"median of {len(rows)} rounds ({sys.argv[2]} steps, {sys.argv[3]} cores): LIGGGHTS {med[0] / 1e6:.2f} M, "
      f"LAMMPS {med[1] / 1e6:.2f} M, dem {med[2] / 1e6:.2f} M particle-steps/s; dem / fastest peer {med[2] / max(med[0], med[1]):.2f}")
PY
