#!/usr/bin/env bash
# CI's performance gate: builds the program in Release (build-count, tests and benchmarks off) and runs
# bench/instructions, which fails when a workload takes more than 3% more instructions per
# particle-step than bench/baselines/instructions.json (valgrind counts: the same on a busy machine).
# Then checks the gate itself: against a baseline 10% below the measured figure it must fail.
set -euo pipefail
cd "$(dirname "$0")/.."
build=build-count
bash scripts/install_deps.sh
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DDEM_BUILD_TESTS=OFF -DDEM_BUILD_BENCH=OFF >/dev/null
cmake --build "$build" -j "$(nproc)" --target dem
bench/instructions --build "$build"
# The gate must be able to fail: a baseline 10% below this build's dense bed.
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
python3 - bench/baselines/instructions.json "$scratch/lower.json" <<'PY'
import json
import sys
b = json.load(open(sys.argv[1]))
b["workloads"] = {"dense_bed": {k: v * 0.9 for k, v in b["workloads"]["dense_bed"].items()}}
json.dump(b, open(sys.argv[2], "w"))
PY
status=0
bench/instructions --build "$build" --only dense_bed --baseline "$scratch/lower.json" > "$scratch/out.txt" || status=$?
if [ "$status" -ne 1 ] || ! grep -q "REGRESSION" "$scratch/out.txt"; then
  cat "$scratch/out.txt"
  echo "instructions.sh: the gate did not flag a baseline 10% below the build (exit $status)" >&2
  exit 1
fi
echo "instructions.sh: the gate flags a 10% increase"
