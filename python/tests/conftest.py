"""Shared setup of the dem module's tests: the built package (PYTHONPATH=<build>/python, set by ctest),
the built `dem` program (DEM_PROGRAM) and the source tree (DEM_SOURCE_DIR)."""
import json
import os
import pathlib
import subprocess

import pytest

SOURCE_DIR = pathlib.Path(os.environ.get("DEM_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
SCENES = SOURCE_DIR / "scenes"



@pytest.fixture
def dem_program():
    program = os.environ.get("DEM_PROGRAM")
    if not program:
        pytest.fail("DEM_PROGRAM is not set: run the tests through ctest, or set it to the built dem program")
    return program


def dem_run(program, scene, out, until, overrides=()):
    """Runs `dem run` and returns its summary.json."""
    args = [program, "run", str(scene), "--until", repr(until), "--quiet", "--out", str(out)]
    for o in overrides:
        args += ["--set", o]
    subprocess.run(args, check=True, cwd=out.parent, stdout=subprocess.DEVNULL)
    with open(out / "summary.json") as f:
        return json.load(f)
