#!/bin/sh
# Installs the built project into a temporary prefix, then builds two outside projects against it
# with find_package(dem): tests/install_consumer (run on the seed slope, output checked) and
# examples/ standalone (built and started), configured with the parent build's generator, make
# program and C++ compiler so that nothing beyond what built the project is needed.
# Usage: install_test.sh <build dir> <source dir> <generator> <make program> <c++ compiler>
set -eu
[ $# -eq 5 ] || { echo "usage: install_test.sh <build dir> <source dir> <generator> <make program> <c++ compiler>" >&2; exit 2; }
build=$1
src=$2
generator=$3
make_program=$4
cxx=$5
work=$(mktemp -d "${TMPDIR:-/tmp}/dem_install_test.XXXXXX")
trap 'rm -rf "$work"' EXIT
prefix=$work/prefix
fail() { echo "install_test: $*" >&2; exit 1; }

cmake --install "$build" --prefix "$prefix" > "$work/install.log" || { cat "$work/install.log"; fail "install failed"; }
for f in include/engine/world.h include/engine/scene_loader.h include/broadphase/candidate_pairs.h; do
  [ -f "$prefix/$f" ] || fail "not installed: $f"
done
for f in cmake/dem/demConfig.cmake cmake/dem/demConfigVersion.cmake cmake/dem/demTargets.cmake libdem_engine.* \
         libdem_broadphase.*; do
  ls "$prefix"/lib*/$f > /dev/null 2>&1 || fail "not installed: lib/$f"
done
[ ! -e "$prefix/include/engine/cli" ] || fail "the CLI's headers are private"

configure_and_build() {  # <source> <binary>
  cmake -S "$1" -B "$2" -G "$generator" -DCMAKE_MAKE_PROGRAM="$make_program" -DCMAKE_CXX_COMPILER="$cxx" \
    -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release > "$2.log" 2>&1 ||
    { cat "$2.log"; fail "configuring $1 failed"; }
  grep -q "^dem_DIR:PATH=$prefix/" "$2/CMakeCache.txt" || fail "$1 did not find the installed package"
  grep -qx "CMAKE_GENERATOR:INTERNAL=$generator" "$2/CMakeCache.txt" || fail "$1 was not configured with $generator"
  cmake --build "$2" > "$2.build.log" 2>&1 || { cat "$2.build.log"; fail "building $1 failed"; }
  ! grep -rq -e "-I$src" "$2/CMakeFiles" || fail "$1 compiled against the source tree"
}

configure_and_build "$src/tests/install_consumer" "$work/consumer"
"$work/consumer/consumer" "$src/scenes/seed_slope.toml" 0.5 > "$work/out.txt" || { cat "$work/out.txt"; fail "consumer failed"; }
cat "$work/out.txt"
for line in "syncs 500" "particles 1" "contacts 1" "third_law ok"; do
  grep -qx "$line" "$work/out.txt" || fail "expected '$line'"
done

configure_and_build "$src/examples" "$work/examples"
# The seed slope has no rotating wall: the example says so and exits with 1.
status=0
"$work/examples/mill_power" "$src/scenes/seed_slope.toml" 2> "$work/mill.err" || status=$?
[ "$status" -eq 1 ] && grep -q "no rotating wall" "$work/mill.err" || { cat "$work/mill.err"; fail "mill_power: status $status"; }
echo "install_test: ok"
