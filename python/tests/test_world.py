"""The dem module against analytic oracles, against the `dem` program, and its views' contract."""
import os
import subprocess
import sys

import numpy as np
import pytest

from conftest import SCENES, SOURCE_DIR, dem_run

# Without numpy or the built module these tests cannot run at all: skip them all, saying why. Under
# ctest the build made the module (DEM_PYTHON_REQUIRED), so failing to import it is an error there.
if os.environ.get("DEM_PYTHON_REQUIRED"):
    import numpy as np

    import dem
else:
    np = pytest.importorskip("numpy", reason="numpy is absent: apt-get install python3-numpy (scripts/install_deps.sh)")
    dem = pytest.importorskip(
        "dem", reason="the dem module is not built or not on PYTHONPATH "
        "(needs pybind11-dev; PYTHONPATH=<build>/python)")

FREE_FLIGHT = """
[scene]
gravity = [0.3, -0.2, -9.81]

[[contacts]]
normal_stiffness = 1e4

[[particles]]
position = [0.1, -0.2, 1.5]
velocity = [1.0, 0.5, 2.0]
radius = 0.01
density = 2500.0

[[particles]]
position = [-0.4, 0.3, 0.7]
velocity = [-0.5, 0.25, 0.0]
radius = 0.02
density = 2500.0

[integrator]
dt = 1e-4

[run]
until = 0.25
"""


def test_free_flight_follows_the_parabola_to_round_off():
    # docs/physics.md 8.1: x(t) = x0 + v0 t + g t^2 / 2, v(t) = v0 + g t, to round-off growing like n eps |x|.
    world = dem.World.from_toml(FREE_FLIGHT)
    x0 = world.positions.copy()
    v0 = world.velocities.copy()
    g = np.array([0.3, -0.2, -9.81])
    checked = []

    def check(w):
        t = w.time
        steps = t / 1e-4
        x = x0 + v0 * t + 0.5 * g * t * t
        v = v0 + g * t
        tol = 4 * steps * np.finfo(float).eps * 2.0
        assert np.abs(w.positions - x).max() <= tol, (t, np.abs(w.positions - x).max(), tol)
        assert np.abs(w.velocities - v).max() <= tol
        checked.append(t)

    world.run_until(0.25, check)
    assert len(checked) > 10 and checked[-1] >= 0.25


def test_head_on_collision_restitution_matches_the_analytic_value():
    # docs/physics.md 8.2: force-zero convention, zeta = 0.1: e = 0.74408 at 1 m/s closing speed.
    world = dem.World.from_scene(str(SCENES / "head_on.toml"))
    world.run_until(0.02)
    v = world.velocities
    closing_after = v[1, 0] - v[0, 0]
    # Within the step's discretisation error of the force-zero value, far from the overlap one (0.72925).
    assert closing_after == pytest.approx(0.74408, abs=1e-3)
    # The centre of mass is unaffected by the impact.
    assert v[0, 0] + v[1, 0] == pytest.approx(0.0, abs=1e-12)


MILL_UNTIL = 1.05
MILL_SET = ["mill.ramp_time=0", "mill.discard_revolutions=0"]


def test_mill_power_draw_and_state_hash_equal_dem_run(dem_program, tmp_path):
    # The mill shortened to one steady revolution (as tests/install_test.sh runs it): the power draw
    # from MillMonitor at every sync time, and the state hash, bit-equal to `dem run`'s.
    summary = dem_run(dem_program, SCENES / "mill_2d.toml", tmp_path / "run", MILL_UNTIL, MILL_SET)
    world = dem.World.from_scene(str(SCENES / "mill_2d.toml"), overrides=MILL_SET)
    monitor = dem.MillMonitor(world)
    revolutions = []
    world.run_until(MILL_UNTIL, lambda w: revolutions.extend(monitor.observe(w)))
    assert len(revolutions) == 1 and revolutions[0]["steady"]
    assert monitor.mean_power_draw is not None
    assert monitor.mean_power_draw == summary["mean_power_draw"]  # to the bit
    assert world.time == summary["time"]
    assert world.state_hash() == summary["state_hash"]


def test_state_hash_equals_dem_run_on_another_scene_and_thread_count(dem_program, tmp_path):
    summary = dem_run(dem_program, SCENES / "seed_slope.toml", tmp_path / "run", 0.3)
    world = dem.World.from_scene(str(SCENES / "seed_slope.toml"), overrides=["run.threads=2"])
    world.run_until(0.3)
    assert len(world.state_hash()) == 16
    assert world.state_hash() == summary["state_hash"]


def test_views_are_views_with_the_right_shapes_and_types_and_values():
    world = dem.World.from_scene(str(SCENES / "mill_2d.toml"))
    n = world.particle_count
    assert n > 100
    for name, dtype, shape in [("positions", np.float64, (n, 3)), ("velocities", np.float64, (n, 3)),
                               ("angular_velocities", np.float64, (n, 3)), ("radii", np.float64, (n,)),
                               ("ids", np.uint32, (n,)), ("levels", np.int8, (n,))]:
        a, b = getattr(world, name), getattr(world, name)
        assert a.dtype == dtype and a.shape == shape, name
        assert not a.flags.writeable, name
        assert not a.flags.owndata and a.base is not None, name
        # Two fetches share the World's memory: neither is a copy.
        assert np.shares_memory(a, b), name
        assert a.__array_interface__["data"][0] == b.__array_interface__["data"][0], name
    # A view keeps its World alive.
    x = world.positions
    del world
    assert np.isfinite(x).all()

    world = dem.World.from_scene(str(SCENES / "mill_2d.toml"))
    ids = world.ids
    x, v = world.positions, world.velocities
    # Values equal what the C++ side holds, looked up by id (World::position, World::velocity).
    for slot in [0, 1, len(ids) // 2, len(ids) - 1]:
        assert world.index_of(int(ids[slot])) == slot
        assert np.array_equal(world.position(int(ids[slot])), x[slot])
        assert np.array_equal(world.velocity(int(ids[slot])), v[slot])
    assert np.all(np.diff(ids.astype(np.int64)) > 0)  # storage order is id order
    # Advancing moves values in place (no particle added or removed: the World's arrays keep their
    # buffers), so the views fetched before show the new state without being fetched again.
    before = x.copy()
    world.run_until(0.05)
    assert not np.array_equal(x, before)
    assert np.array_equal(x, world.positions)
    assert np.array_equal(v, world.velocities)
    for slot in [0, len(ids) - 1]:
        assert np.array_equal(world.position(int(ids[slot])), x[slot])


def test_a_bad_scene_raises_the_loaders_message(dem_program, tmp_path):
    scene = tmp_path / "bad.toml"
    scene.write_text((SCENES / "head_on.toml").read_text().replace("normal_stiffness = 1e5", "normal_stifness = 1e5"))
    with pytest.raises(dem.InputError) as raised:
        dem.World.from_scene(str(scene))
    assert isinstance(raised.value, ValueError)
    check = subprocess.run([dem_program, "check", str(scene)], capture_output=True, text=True)
    assert check.returncode == 2
    assert check.stderr.strip() == "dem: error: " + str(raised.value)
    assert "normal_stifness" in str(raised.value)
    # An override the loader rejects, and TOML text, raise the same way.
    with pytest.raises(dem.InputError, match="integrator.dt"):
        dem.World.from_scene(str(SCENES / "head_on.toml"), overrides=["integrator.dt=-1"])
    with pytest.raises(dem.InputError, match="^text.toml:"):
        dem.World.from_toml("[scene]\nbogus = 1\n", name="text.toml")


def test_set_velocity_is_an_impulse_the_books_see():
    # docs/physics.md 8.1: from the new velocity on, particle 0 flies as x0 + v0 t + g t^2 / 2.
    world = dem.World.from_toml(FREE_FLIGHT)
    world.run_until(0.05)
    assert not world.set_velocity(7, [0.0, 0.0, 1.0])
    assert not world.set_velocity(0, [float("nan"), 0.0, 0.0])
    x0, t0 = np.array(world.position(0)), world.time
    v0 = np.array([0.5, -1.0, 3.0])
    assert world.set_velocity(0, v0)
    e = world.energies()
    assert e["given"] != 0
    assert abs(e["balance_error"]) <= 1e-9 * e["balance_scale"]
    world.run_until(0.25)
    t = world.time - t0
    g = np.array([0.3, -0.2, -9.81])
    assert np.allclose(world.position(0), x0 + v0 * t + 0.5 * g * t * t, rtol=0, atol=1e-12)


def test_add_and_remove_particles_between_sync_intervals():
    world = dem.World.from_toml(FREE_FLIGHT)
    assert world.particle_count == 2 and sorted(world.ids) == [0, 1]
    assert not world.is_free([0.1, -0.2, 1.5], 0.01)
    with pytest.raises(ValueError):
        world.add_particle([0.1, -0.2, 1.5], 0.01)  # overlaps particle 0
    with pytest.raises(ValueError):
        world.add_particle([5.0, 5.0, 5.0], 0.01, material="nonexistent")
    added = []

    def feed_and_discharge(w):
        if len(added) < 3:
            added.append(w.add_particle([2.0 + len(added), 0.0, 0.0], 0.01, velocity=[0.0, 1.0, 0.0], density=2500.0))
        elif len(added) == 3:
            assert w.remove_particle(0)
            assert not w.remove_particle(0)
            added.append(None)

    world.run_until(0.01, feed_and_discharge)
    # New ids are one past the largest ever given, never reused; a removed id leaves the ids view.
    assert added[:3] == [2, 3, 4]
    assert world.particle_count == 4
    assert sorted(world.ids) == [1, 2, 3, 4]
    assert world.index_of(0) is None and world.ids[world.index_of(4)] == 4
    with pytest.raises(IndexError):
        world.position(0)
    assert world.radii[world.index_of(4)] == 0.01 and world.positions.shape == (4, 3)
    # The energy books stay balanced (the removed particle's energy is booked as carried out).
    e = world.energies()
    assert e["removed"] > 0
    assert abs(e["balance_error"]) <= 1e-9 * e["balance_scale"]
    assert world.add_particle([9.0, 0.0, 0.0], 0.01) == 5


def test_callback_can_stop_the_run_and_exceptions_propagate():
    world = dem.World.from_toml(FREE_FLIGHT)
    calls = []
    world.run_until(0.25, lambda w: calls.append(w.time) or len(calls) < 3)
    assert len(calls) == 3 and world.time == calls[-1] < 0.25

    # Only False stops: a callback returning a value for its own use runs on.
    world.run_until(0.05, lambda w: [])
    assert world.time >= 0.05

    def boom(w):
        raise KeyError("from the callback")

    with pytest.raises(KeyError, match="from the callback"):
        world.run_until(0.25, boom)


def test_contact_forces_and_wall_loads_obey_newtons_third_law():
    world = dem.World.from_scene(str(SCENES / "mill_2d.toml"))
    world.run_until(0.2)
    c = world.contact_forces()
    force, torque = world.wall_loads()
    assert force.shape == (len(world.wall_names), 3) and torque.shape == force.shape
    walls = c["wall"]
    assert (walls >= 0).any() and (walls < 0).any()
    pairs = walls < 0
    assert np.all(c["i"][pairs] < c["j"][pairs])
    for w in np.unique(walls[walls >= 0]):
        total = -c["force"][walls == w].sum(axis=0)
        assert np.allclose(total, force[w], rtol=1e-9, atol=1e-12)


def test_example_mill_power_script_draws_its_png(tmp_path):
    png = tmp_path / "power.png"
    script = SOURCE_DIR / "examples" / "python" / "mill_power.py"
    subprocess.run([sys.executable, str(script), str(SCENES / "mill_2d.toml"), "--until", "1.05",
                    "--set", "mill.ramp_time=0", "--set", "mill.discard_revolutions=0", "--png", str(png)],
                   check=True, cwd=tmp_path)
    data = png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 1000
