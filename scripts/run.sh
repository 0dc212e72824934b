#!/usr/bin/env bash
# The README's run command: installs what is missing, builds Release and runs the default scene
# (a 2D ball mill, printing its power draw per revolution), writing its outputs to out/mill_2d/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DDEM_BUILD_TESTS=OFF
cmake --build build -j "$(nproc)"
./build/engine/dem check scenes/mill_2d.toml > /dev/null
./build/engine/dem run scenes/mill_2d.toml "$@"
