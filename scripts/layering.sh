#!/usr/bin/env bash
# The layering rules of docs/design.md, Layering, that a grep can check (scripts/test.sh runs this as
# its "layering check" stage; run it alone with `bash scripts/layering.sh`). Prints every offending
# include and exits 1 if any rule is broken.
set -euo pipefail
cd "$(dirname "$0")/.."
failed=0
fail() {
  echo "layering: $1" >&2
  failed=1
}

# The edges of engine/: the loader side (scene files, particle CSVs, STL files), the writers (whole
# files, CSV, JSON, VTK and what they show, checkpoint files) and the program. Every other file of
# engine/ is the core.
loader='engine/(scene_[a-z_]+|toml_reader|particle_csv|stl_reader)\.(h|cpp)'
writer_names='atomic_file|csv_writer|json_writer|vtk_writer|vtk_snapshots|wall_geometry|number_text'
writers="engine/($writer_names|checkpoint)\.(h|cpp)"
edges="^($loader|$writers|engine/cli/.*)$"
core=$(find engine -name '*.h' -o -name '*.cpp' | sort | grep -Ev "$edges")

# 1. broadphase/ never includes engine/.
if grep -rn '#include *"engine/' broadphase; then
  fail "broadphase/ must not include engine/ headers"
fi

# 2. The core reads and writes no files: no file-I/O header. checks.h may use <cstdio>: a failed
#    check is reported on stderr just before the program aborts.
# shellcheck disable=SC2086
if grep -nE '#include *<(fstream|filesystem|cstdio)>' $core | grep -v '^engine/checks\.h:'; then
  fail "the core of engine/ must not include file-I/O headers (<fstream>, <filesystem>, <cstdio>): files are read by the loader side and written by the writers"
fi

# 3. The core does not call the loader side or the writers: none of their headers. (checkpoint.h
#    declares the state hash too, which the core keeps; its file I/O is in checkpoint.cpp.)
# shellcheck disable=SC2086
if grep -nE "#include *\"engine/(scene_[a-z_]+|toml_reader|particle_csv|stl_reader|$writer_names)\.h\"" $core; then
  fail "the core of engine/ must not include loader or writer headers"
fi

# 4. toml++ is used by the loader side only (and the loader's fuzzer, which builds TOML documents).
if grep -rnE '#include *<toml\+\+/' engine broadphase tests bench examples | grep -Ev "^$loader:"; then
  fail "only the loader side (engine/scene_*, toml_reader.*, particle_csv.*, stl_reader.*) may include toml++"
fi

exit $failed
