#!/usr/bin/env bash
# The README's run command: installs what is missing, builds Release and runs the default scene
# (the seed paper's slope test), writing its outputs to out/seed_slope/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DDEM_BUILD_TESTS=OFF
cmake --build build -j "$(nproc)"
./build/engine/dem check scenes/seed_slope.toml
./build/engine/dem run scenes/seed_slope.toml "$@"
