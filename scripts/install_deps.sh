#!/usr/bin/env bash
# Installs, with apt-get, whatever the build needs and this Debian bookworm machine lacks
# (compiler and CMake included). Idempotent: installed packages are skipped. Run as root.
#   bash scripts/install_deps.sh             the build's packages
#   bash scripts/install_deps.sh PKG ...     these packages instead (e.g. the fuzzer's clang)
set -euo pipefail
# libbenchmark-tools, python3-numpy and python3-scipy: bench/regress and its tests (compare.py);
# valgrind: bench/instructions, CI's instruction-count gate; python3-matplotlib: the plots dem run and
# dem trade draw and the bench/ plotting scripts; python3-vtk9: tests/vtk_reader_test.py reads the VTK
# snapshots with VTK's own reader; pybind11-dev and python3-dev: the Python module dem (python/),
# python3-pytest: its tests.
packages=(g++ cmake ninja-build git
  libeigen3-dev libtbb-dev libnanoflann-dev libgtest-dev libbenchmark-dev libbenchmark-tools
  python3-numpy python3-scipy python3-matplotlib python3-vtk9 libtomlplusplus-dev libcli11-dev valgrind
  pybind11-dev python3-dev python3-pytest)
if [ $# -gt 0 ]; then packages=("$@"); fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# python3-paraview ships the same VTK Python modules and conflicts with python3-vtk9: where it is
# installed, it serves the test and is left alone (installing python3-vtk9 would remove it).
if dpkg-query -W -f='${Status}' python3-paraview 2>/dev/null | grep -q "install ok installed"; then
  kept=()
  for p in "${missing[@]}"; do [ "$p" = python3-vtk9 ] || kept+=("$p"); done
  missing=("${kept[@]}")
fi
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
