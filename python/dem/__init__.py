"""dem: the discrete element engine driven from Python (docs/python.md).

    import dem
    world = dem.World.from_scene("scenes/mill_2d.toml", overrides=["run.threads=2"])
    world.run_until(0.5, lambda w: print(w.time, w.particle_count))
    world.positions      # N x 3 read-only numpy view, storage order; world.ids maps slot -> id
    world.state_hash()   # the hex string `dem run` prints

Built for Debian's /usr/bin/python3; after the build, PYTHONPATH=build/python finds this package.
"""
from ._core import DivergedError, InputError, MillMonitor, World

__all__ = ["World", "MillMonitor", "InputError", "DivergedError"]

for _name in __all__:  # shown as dem.World, dem.InputError, ... rather than dem._core.*
    globals()[_name].__module__ = "dem"
