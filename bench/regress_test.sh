#!/usr/bin/env bash
# The ctest cases of bench/regress (issue 6, part 4), on its --quick subset; run serially:
#   regress_test.sh baseline BUILD DIR   a fresh run of BUILD becomes DIR/baseline.json
#   regress_test.sh fresh BUILD DIR      another fresh run of the same build passes (exit code 0)
#   regress_test.sh slowdown BUILD DIR   the hook adds 25% to grid_build_and_pairs/10000: exit code 1,
#                                        that benchmark flagged as a regression and named
set -uo pipefail
mode=$1 build=$2 dir=$3
regress="$(dirname "$0")/regress"
target=grid_build_and_pairs/10000
mkdir -p "$dir"
run() {  # run LOG ARGS...: bench/regress --quick against DIR/baseline.json, output to LOG too
  local log=$1
  shift
  "$regress" --quick --build "$build" --baseline "$dir/baseline.json" "$@" 2>&1 | tee "$log"
  return "${PIPESTATUS[0]}"
}
case $mode in
  baseline)
    run "$dir/baseline.log" --update-baseline --out "$dir/baseline_run.json"
    ;;
  fresh)
    run "$dir/fresh.log" --out "$dir/fresh.json"
    rc=$?
    if [ "$rc" -ne 0 ]; then
      echo "regress_test: two fresh runs of one build must pass; bench/regress exited with $rc" >&2
      exit 1
    fi
    ;;
  slowdown)
    DEM_BENCH_SLOWDOWN="$target:0.25" run "$dir/slowdown.log" --out "$dir/slowdown.json"
    rc=$?
    if [ "$rc" -ne 1 ]; then
      echo "regress_test: a 25% slowdown of $target must fail with exit code 1; got $rc" >&2
      exit 1
    fi
    if ! grep -q "^bench_broadphase/$target .*REGRESSION" "$dir/slowdown.log" ||
       ! grep -q "^FAIL: .*bench_broadphase/$target" "$dir/slowdown.log"; then
      echo "regress_test: bench/regress failed but did not name $target as the regression" >&2
      exit 1
    fi
    ;;
  *)
    echo "usage: regress_test.sh baseline|fresh|slowdown BUILD DIR" >&2
    exit 2
    ;;
esac
