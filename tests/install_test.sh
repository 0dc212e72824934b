#!/bin/sh
# Installs the built project into a temporary prefix and uses only what was installed:
#   - the layout: bin/dem, headers under include/dem/ (nothing at include/engine), the CMake package,
#     the scenes with their data files and the plotting scripts under share/dem/, and the Python module
#     (when built) under lib/python3.X/dist-packages/, importable from there;
#   - the installed `dem`: --help, --version, `check` of every installed scene, and a short run of the
#     installed 2D mill that draws spectra.png with the installed plotting script; a copy of the
#     prefix elsewhere finds its own share/dem (from the executable's path, not a compiled-in one)
#     and, its plotting script removed, draws nothing rather than reach into the source tree;
#   - two outside projects built against the package with find_package(dem), configured with the
#     parent build's generator, make program and C++ compiler (nothing beyond what built the
#     project is needed): tests/install_consumer (run on the installed seed slope, output checked)
#     and examples/ (mill_power on the same mill run as `dem run`: the same mean power draw).
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
# A PNG file: its 8-byte signature, and more than a header.
is_png() {
  [ -f "$1" ] && [ "$(head -c 8 "$1" | od -An -tx1 | tr -d ' \n')" = "89504e470d0a1a0a" ] && [ "$(wc -c < "$1")" -gt 1000 ]
}

# ---- layout ----------------------------------------------------------------------------------------
cmake --install "$build" --prefix "$prefix" > "$work/install.log" || { cat "$work/install.log"; fail "install failed"; }
for f in bin/dem include/dem/engine/world.h include/dem/engine/scene_loader.h include/dem/engine/mill_monitor.h \
         include/dem/broadphase/candidate_pairs.h share/dem/scripts/plot_spectra.py share/dem/scripts/plot_trade.py \
         share/dem/scenes/README.md; do
  [ -f "$prefix/$f" ] || fail "not installed: $f"
done
[ -x "$prefix/bin/dem" ] || fail "bin/dem is not executable"
for f in cmake/dem/demConfig.cmake cmake/dem/demConfigVersion.cmake cmake/dem/demTargets.cmake libdem_engine.* \
         libdem_broadphase.*; do
  ls "$prefix"/lib*/$f > /dev/null 2>&1 || fail "not installed: lib/$f"
done
# Every shipped scene and data file, byte for byte.
(cd "$src" && find scenes -type f) | while read -r f; do
  cmp -s "$src/$f" "$prefix/share/dem/$f" || fail "not installed: share/dem/$f"
done
for d in engine broadphase; do
  [ ! -e "$prefix/include/$d" ] || fail "include/$d installed: headers belong under include/dem"
done
[ ! -e "$prefix/include/dem/engine/cli" ] || fail "the CLI's headers are private"
# The Python module, when the build made it: installed for Debian's python3, and importable from there.
if [ -f "$build/python/dem/__init__.py" ]; then
  site=$(ls -d "$prefix"/lib/python3.*/dist-packages 2> /dev/null) || fail "the Python module is not installed"
  (cd "$work" && PYTHONPATH=$site /usr/bin/python3 -c "import dem, sys; sys.exit(not dem.__file__.startswith(sys.argv[1]))" \
    "$site") ||
    fail "the installed Python module does not import from $site"
fi

# ---- the installed program -------------------------------------------------------------------------
dem=$prefix/bin/dem
scenes=$prefix/share/dem/scenes
"$dem" --help > "$work/help.txt" 2>&1 || { cat "$work/help.txt"; fail "dem --help failed"; }
grep -q "run" "$work/help.txt" || { cat "$work/help.txt"; fail "dem --help lists no run command"; }
"$dem" --version > "$work/version.txt" 2>&1 || { cat "$work/version.txt"; fail "dem --version failed"; }
grep -qx "plot scripts: $prefix/share/dem/scripts" "$work/version.txt" ||
  { cat "$work/version.txt"; fail "the installed dem does not take its plot scripts from $prefix/share/dem/scripts"; }
# `check` loads each installed scene with its data files (particle sets, an STL liner).
for scene in "$scenes"/*.toml; do
  "$dem" check "$scene" > "$work/check.log" 2>&1 || { cat "$work/check.log"; fail "dem check $scene failed"; }
done

# The mill, shortened to one steady revolution: no start-up ramp and no discarded revolution, so the
# first revolution (1.03 s) counts in mean_power_draw. The example below runs the same scene.
mill_until=1.05
set -- --set mill.ramp_time=0 --set mill.discard_revolutions=0
(cd "$work" && "$dem" run "$scenes/mill_2d.toml" --until $mill_until "$@" --quiet --out "$work/mill") \
  > "$work/mill.log" 2>&1 || { cat "$work/mill.log"; fail "dem run of the installed mill failed"; }
is_png "$work/mill/spectra.png" || { cat "$work/mill.log"; fail "the installed dem drew no spectra.png"; }

# A copy of the prefix elsewhere: share/dem is found beside the executable wherever it is, and the
# source tree is never read: without its own plot_spectra.py the copy draws nothing.
cp -R "$prefix" "$work/moved"
"$work/moved/bin/dem" --version | grep -qx "plot scripts: $work/moved/share/dem/scripts" ||
  { "$work/moved/bin/dem" --version; fail "a moved prefix does not use its own share/dem"; }
rm "$work/moved/share/dem/scripts/plot_spectra.py"
"$work/moved/bin/dem" run "$work/moved/share/dem/scenes/mill_2d.toml" --until 0.02 --quiet --out "$work/moved_mill" \
  > "$work/moved.log" 2>&1 || { cat "$work/moved.log"; fail "dem run of the moved prefix failed"; }
[ -f "$work/moved_mill/spectra.csv" ] && [ ! -e "$work/moved_mill/spectra.png" ] &&
  grep -q "$work/moved/share/dem/scripts/plot_spectra.py not found" "$work/moved.log" ||
  { cat "$work/moved.log"; fail "without its plot script the moved dem still drew spectra.png (from the source tree?)"; }

# ---- outside projects ------------------------------------------------------------------------------
configure_and_build() {  # <source> <binary>
  cmake -S "$1" -B "$2" -G "$generator" -DCMAKE_MAKE_PROGRAM="$make_program" -DCMAKE_CXX_COMPILER="$cxx" \
    -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release -DCMAKE_EXPORT_COMPILE_COMMANDS=ON > "$2.log" 2>&1 ||
    { cat "$2.log"; fail "configuring $1 failed"; }
  grep -q "^dem_DIR:PATH=$prefix/" "$2/CMakeCache.txt" || fail "$1 did not find the installed package"
  grep -qx "CMAKE_GENERATOR:INTERNAL=$generator" "$2/CMakeCache.txt" || fail "$1 was not configured with $generator"
  cmake --build "$2" > "$2.build.log" 2>&1 || { cat "$2.build.log"; fail "building $1 failed"; }
  # The compile lines (any generator): the package's headers from include/dem, none from the source tree.
  grep -q -e "$prefix/include/dem\b" "$2/compile_commands.json" || fail "$1 was not compiled against $prefix/include/dem"
  ! grep -q -e "-I *$src\|-isystem *$src" "$2/compile_commands.json" || fail "$1 compiled against the source tree"
}

configure_and_build "$src/tests/install_consumer" "$work/consumer"
"$work/consumer/consumer" "$scenes/seed_slope.toml" 0.5 > "$work/out.txt" || { cat "$work/out.txt"; fail "consumer failed"; }
cat "$work/out.txt"
for line in "syncs 500" "particles 1" "contacts 1" "third_law ok"; do
  grep -qx "$line" "$work/out.txt" || fail "expected '$line'"
done

configure_and_build "$src/examples" "$work/examples"
# The seed slope has no [mill] section: the example says so and exits with 1.
status=0
"$work/examples/mill_power" "$scenes/seed_slope.toml" 2> "$work/seed.err" || status=$?
[ "$status" -eq 1 ] && grep -q "no \[mill\] section" "$work/seed.err" || { cat "$work/seed.err"; fail "mill_power: status $status"; }
(cd "$work" && "$work/examples/mill_power" "$scenes/mill_2d.toml" --until $mill_until "$@") > "$work/mill_power.txt" ||
  { cat "$work/mill_power.txt"; fail "mill_power on the installed mill failed"; }
cat "$work/mill_power.txt"
# The same figure to the bit: the same scene and end time, the same library code (MillMonitor over the
# drive work the World integrates every step), and results that do not depend on the thread count or
# on the program around the library (-ffp-contract=off comes with the package). Any difference is a bug.
example=$(sed -n 's/^mean_power_draw //p' "$work/mill_power.txt")
[ -n "$example" ] || fail "mill_power printed no mean_power_draw"
/usr/bin/python3 - "$work/mill/summary.json" "$example" <<'EOF' || fail "the example's power draw differs from dem run's"
import json, sys
run = json.load(open(sys.argv[1]))["mean_power_draw"]
example = float(sys.argv[2])
print(f"mean_power_draw: dem run {run!r} W, mill_power {example!r} W")
sys.exit(0 if run == example else 1)
EOF
echo "install_test: ok"
