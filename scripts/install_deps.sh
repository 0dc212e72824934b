#!/usr/bin/env bash
# Installs, with apt-get, whatever the build needs and this Debian bookworm machine lacks
# (compiler and CMake included). Idempotent: installed packages are skipped. Run as root.
#   bash scripts/install_deps.sh             the build's packages
#   bash scripts/install_deps.sh PKG ...     these packages instead (e.g. the fuzzer's clang)
set -euo pipefail
# libbenchmark-tools, python3-numpy and python3-scipy: bench/regress and its tests (compare.py);
# valgrind: bench/instructions, CI's instruction-count gate; python3-matplotlib: the plots dem run and
# dem trade draw and the bench/ plotting scripts; pybind11-dev and python3-dev: the Python module dem
# (python/), python3-pytest: its tests.
packages=(g++ cmake ninja-build git
  libeigen3-dev libtbb-dev libnanoflann-dev libgtest-dev libbenchmark-dev libbenchmark-tools
  python3-numpy python3-scipy python3-matplotlib libtomlplusplus-dev libcli11-dev valgrind
  pybind11-dev python3-dev python3-pytest)
if [ $# -gt 0 ]; then packages=("$@"); fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
