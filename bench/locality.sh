#!/usr/bin/env bash
# What memory order costs: the dense bed (scenes/dense_bed.toml) from its particle file as shipped,
# where the settled spheres lie layer by layer so that contact partners sit near each other in memory,
# against the same spheres in a shuffled order (a fixed permutation; the file's ids dropped, so slots
# follow the new order), and that shuffled bed re-sorted in memory by the engine
# (broadphase.sort_interval = 1000: at the first candidate rebuild, before the first step). All do
# the same work to round-off: only where each particle's data lies in memory differs. Interleaved in
# every round, on 1 and on THREADS threads; prints each run's wall time (summary.json, steps only),
# then per thread count the median over the rounds of each run's time over the ordered one's.
# Needs a Release build in build/.
# Usage: bench/locality.sh [ROUNDS (default 3)] [UNTIL (default 0.0145 s, 2,000 steps)] [THREADS (default 2)]
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=${1:-3}
until=${2:-0.0145}
threads=${3:-2}
[ -x build/engine/dem ] || { echo "build/engine/dem not found: build Release in build/ first" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/data"
cp scenes/dense_bed.toml "$work/"
python3 - scenes/data/dense_bed_settled.csv "$work/data/dense_bed_settled.csv" <<'PY'
import csv
import random
import sys
with open(sys.argv[1], newline="") as f:
    rows = list(csv.reader(f))
header, body = rows[0], rows[1:]
random.Random(1).shuffle(body)
drop = header.index("id")
with open(sys.argv[2], "w", newline="") as f:
    out = csv.writer(f)
    for row in [header] + body:
        out.writerow(row[:drop] + row[drop + 1:])
PY
times=$work/times.txt
: > "$times"
for round in $(seq "$rounds"); do
  for t in 1 "$threads"; do
    for order in ordered shuffled resorted; do
      scene=scenes/dense_bed.toml
      [ "$order" != ordered ] && scene=$work/dense_bed.toml
      sort_interval=0
      [ "$order" = resorted ] && sort_interval=1000
      build/engine/dem run "$scene" --threads "$t" --until "$until" --quiet --out "$work/$order" \
        --set output.snapshot_interval=1 --set output.interval=1 --set broadphase.sort_interval=$sort_interval
      wall=$(python3 -c "import json, sys; print(json.load(open(sys.argv[1]))['wall_time'])" "$work/$order/summary.json")
      echo "round $round, $t thread(s), $order: $wall s"
      echo "$round $t $order $wall" >> "$times"
    done
  done
done
python3 - "$times" <<'PY'
import collections
import statistics
import sys
wall = {}
for line in open(sys.argv[1]):
    round_, threads, order, seconds = line.split()
    wall[(round_, threads, order)] = float(seconds)
ratios = collections.defaultdict(list)
for (round_, threads, order), seconds in wall.items():
    if order != "ordered":
        ratios[(threads, order)].append(seconds / wall[(round_, threads, "ordered")])
for threads, order in sorted(ratios, key=lambda k: (int(k[0]), k[1])):
    r = ratios[(threads, order)]
    print(f"{threads} thread(s): {order} / ordered wall time, median of {len(r)}: {statistics.median(r):.2f}"
          f" (rounds: {', '.join(f'{x:.2f}' for x in r)})")
PY
