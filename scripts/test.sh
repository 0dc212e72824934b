#!/usr/bin/env bash
# The README's test command and CI's only command: installs what is missing, configures, builds and
# runs every CI stage (warnings as errors, costly invariants checked; the instruction-count gate on a
# Release build, scripts/instructions.sh; then 60 s of fuzzing the scene
# loader with clang's libFuzzer and sanitizers, scripts/fuzz.sh; then the sanitizer builds,
# scripts/sanitize.sh: ASan + UBSan on the `sanitize` tests, ThreadSanitizer with the std::thread
# backend on the `tsan` tests), printing each stage's time.
# Long validation (ctest label `long`) is skipped here: run `ctest --test-dir build-test -L long`.
set -euo pipefail
cd "$(dirname "$0")/.."
build=build-test
jobs=$(nproc)

stage() {
  local name=$1
  shift
  local start=$SECONDS
  echo "== $name"
  "$@"
  echo "== $name: $((SECONDS - start)) s"
}

stage "install dependencies" bash scripts/install_deps.sh
stage "layering check" bash scripts/layering.sh
stage "configure" cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDEM_WERROR=ON -DDEM_VALIDATE=ON
stage "build" cmake --build "$build" -j "$jobs"
stage "tests" ctest --test-dir "$build" -LE long --output-on-failure -j "$jobs" --timeout 300
stage "instruction counts" bash scripts/instructions.sh
stage "fuzz scene loader (60 s)" bash scripts/fuzz.sh 60
stage "sanitize (ASan+UBSan)" bash scripts/sanitize.sh address
stage "tsan" bash scripts/sanitize.sh thread
echo "== total: $SECONDS s"
