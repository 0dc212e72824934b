#!/usr/bin/env bash
# Fuzzes the scene loader: installs clang and its runtime if missing, builds
# fuzz/scene_loader_fuzz (libFuzzer, AddressSanitizer, UndefinedBehaviorSanitizer) in build-fuzz and
# runs it for a bounded time on the shipped scenes, the malformed scenes of tests/scenes/bad and
# fuzz/corpus, with new inputs kept in build-fuzz/corpus. Exits non-zero on any finding (crash,
# sanitizer report, an exception other than dem::InputError, an input slower than 5 s, more than
# 2 GB), printing the reproducer; replay one with `build-fuzz/scene_loader_fuzz FILE`.
#   bash scripts/fuzz.sh [SECONDS]        (default 60; also DEM_FUZZ_SECONDS)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-${DEM_FUZZ_SECONDS:-60}}
build=build-fuzz

bash scripts/install_deps.sh                           # cmake, ninja and the libraries
bash scripts/install_deps.sh clang libclang-rt-14-dev  # the fuzzer's compiler and runtime

cmake -S fuzz -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ >/dev/null
cmake --build "$build" -j 2

# The first corpus folder is the writable one, where libFuzzer adds inputs that reach new code; the
# seed folders are read only (their CSV files, scenes/data, are read too, cut to -max_len). One
# process: no -jobs, with which libFuzzer forks workers that log to ./fuzz-N.log.
mkdir -p "$build/corpus" "$build/artifacts"
rm -f "$build"/artifacts/*
log=$build/fuzz.log
status=0
"$build/scene_loader_fuzz" "$build/corpus" fuzz/corpus scenes tests/scenes/bad \
  -dict=fuzz/scene.dict -max_total_time="$seconds" -timeout=5 -rss_limit_mb=2048 -max_len=8192 \
  -print_final_stats=1 -artifact_prefix="$build/artifacts/" >"$log" 2>&1 || status=$?
# The summary: libFuzzer's final statistics (executions, speed, corpus size).
grep -E '^(stat::|Done|INFO: seed corpus|#[0-9]+[[:space:]]+DONE)' "$log" || true

findings=("$build"/artifacts/*)
if [ "$status" -ne 0 ] || [ -e "${findings[0]}" ]; then
  tail -n 60 "$log" >&2
  echo "fuzz: finding (libFuzzer exit $status); full log: $log" >&2
  for f in "${findings[@]}"; do
    [ -e "$f" ] && echo "fuzz: reproducer: $f (replay: $build/scene_loader_fuzz $f)" >&2
  done
  exit 1
fi
echo "fuzz: no findings in $seconds s"
