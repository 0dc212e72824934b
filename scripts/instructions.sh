#!/usr/bin/env bash
# CI's performance gate: builds the program in Release (build-count; tests, benchmarks and the Python module off:
# with the module the engine libraries are position independent, which is not what the baseline counts) and runs
# bench/instructions, which fails when a workload takes more than 3% more instructions per
# particle-step than bench/baselines/instructions.json (valgrind counts: the same on a busy machine).
# Then checks the gate itself: against a baseline 10% below this build's own figure it must fail.
set -euo pipefail
cd "$(dirname "$0")/.."
build=build-count
bash scripts/install_deps.sh
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DDEM_BUILD_TESTS=OFF -DDEM_BUILD_BENCH=OFF \
  -DDEM_BUILD_PYTHON=OFF >/dev/null
cmake --build "$build" -j "$(nproc)" --target dem
bench/instructions --build "$build"
# The gate must be able to fail: this build's dense bed measured into a scratch baseline, lowered 10%.
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
bench/instructions --build "$build" --only dense_bed --baseline "$scratch/lower.json" --update-baseline > /dev/null
/usr/bin/python3 - "$scratch/lower.json" <<'PY'
import json
import sys
b = json.load(open(sys.argv[1]))
b["workloads"]["dense_bed"]["instructions_per_particle_step"] *= 0.9
json.dump(b, open(sys.argv[1], "w"))
PY
status=0
bench/instructions --build "$build" --only dense_bed --baseline "$scratch/lower.json" > "$scratch/out.txt" || status=$?
if [ "$status" -ne 1 ] || ! grep -q "REGRESSION" "$scratch/out.txt"; then
  cat "$scratch/out.txt"
  echo "instructions.sh: the gate did not flag a baseline 10% below the build (exit $status)" >&2
  exit 1
fi
echo "instructions.sh: the gate flags a 10% increase"
