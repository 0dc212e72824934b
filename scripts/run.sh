#!/usr/bin/env bash
# The README's run command: installs what is missing, builds Release and runs the main job: the
# fixed-step throughput of the two benchmark workloads (20,000 spheres settled and in free flight).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DDEM_BUILD_TESTS=OFF
cmake --build build -j "$(nproc)"
./build/bench/bench_engine --benchmark_min_time=1 "$@"
