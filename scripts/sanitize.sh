#!/usr/bin/env bash
# The sanitizer stages of CI: installs clang and its runtime if missing,
# configures a clang build in its own folder, builds only the test executables its ctest label needs
# and runs them, failing on any sanitizer report. Prints the time of each step.
#   bash scripts/sanitize.sh address   AddressSanitizer + UndefinedBehaviorSanitizer (build-asan):
#                                      ctest label `sanitize`, a broad subset (tests/CMakeLists.txt)
#   bash scripts/sanitize.sh thread    ThreadSanitizer with the std::thread backend of
#                                      broadphase/parallel.h (build-tsan): ctest label `tsan`, the tests
#                                      that run parallel loops on several threads; then three runs of
#                                      the program whose state hashes must equal those of the oneTBB
#                                      build's program (build-test/engine/dem, skipped when not built)
# No suppressions. Every report aborts the process (abort_on_error), so it can never pass for one of
# the program's own exit codes.
set -euo pipefail
cd "$(dirname "$0")/.."
kind=${1:-}
case $kind in
  address) build=build-asan label=sanitize targets=(sanitize_tests) ;;
  thread) build=build-tsan label=tsan targets=(tsan_tests dem) ;;
  *)
    echo "usage: scripts/sanitize.sh address|thread" >&2
    exit 2
    ;;
esac
jobs=$(nproc)

step() {
  local name=$1
  shift
  local start=$SECONDS
  "$@"
  echo "-- $label $name: $((SECONDS - start)) s"
}

export ASAN_OPTIONS=abort_on_error=1:detect_leaks=1
export UBSAN_OPTIONS=abort_on_error=1:print_stacktrace=1
export TSAN_OPTIONS=abort_on_error=1:halt_on_error=1:second_deadlock_stack=1

# The state hash of three runs: std::thread backend on 3 threads against oneTBB on 2.
compare_backends() {
  local reference=build-test/engine/dem
  if [ ! -x "$reference" ]; then
    echo "no $reference (the default build): backend comparison skipped"
    return 0
  fi
  local out status=0
  out=$(mktemp -d)
  while read -r scene args; do
    # shellcheck disable=SC2086  # args are words
    "$reference" run "scenes/$scene.toml" --quiet --threads 2 --out "$out/tbb" --set output.snapshot_interval=0 $args
    # shellcheck disable=SC2086
    "$build/engine/dem" run "scenes/$scene.toml" --quiet --threads 3 --out "$out/std" --set output.snapshot_interval=0 $args
    local tbb std
    tbb=$(grep -o '"state_hash": "[0-9a-f]*"' "$out/tbb/summary.json" | cut -d'"' -f4)
    std=$(grep -o '"state_hash": "[0-9a-f]*"' "$out/std/summary.json" | cut -d'"' -f4)
    echo "$scene $args: oneTBB $tbb, std::thread $std"
    if [ -z "$tbb" ] || [ "$tbb" != "$std" ]; then
      echo "backend comparison: state hashes differ for $scene $args" >&2
      status=1
    fi
    rm -rf "$out/tbb" "$out/std"
  done <<'RUNS'
mill_2d --until 0.04
mill_2d --until 0.04 --set integrator.control=doubling
dense_bed --until 2e-4
RUNS
  rm -rf "$out"
  return $status
}

bash scripts/install_deps.sh                           # cmake, ninja and the libraries
bash scripts/install_deps.sh clang libclang-rt-14-dev  # the compiler and its sanitizer runtimes

# Debug: assertions on (DEM_SANITIZE adds -O1 -g); warnings fatal and costly invariants checked, as in CI.
configure() {
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_COMPILER=clang++ -DDEM_SANITIZE="$kind" \
    -DDEM_WERROR=ON -DDEM_VALIDATE=ON -DDEM_BUILD_BENCH=OFF >/dev/null
}
step configure configure
step build cmake --build "$build" -j "$jobs" --target "${targets[@]}"
step tests ctest --test-dir "$build" -L "$label" --output-on-failure -j "$jobs" --timeout 600
if [ "$kind" = thread ]; then step "backend comparison" compare_backends; fi
