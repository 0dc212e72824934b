// dem._core: the Python binding of the World's embedding API (engine/world.h; docs/python.md).
// A dem.World owns one dem::World and the Scene it was loaded from (its [mill] settings feed
// dem.MillMonitor). State arrays are handed out as numpy views of the World's own vectors, read-only
// (writing a position or velocity behind the World's back would bypass its neighbour lists and energy
// books), with the Python World as their base so the memory outlives no view.
// Errors: dem::InputError becomes dem.InputError (a ValueError) with the same message `dem` prints;
// std::invalid_argument ValueError, std::out_of_range IndexError, other std exceptions RuntimeError
// (pybind11's mapping); a diverged run raises dem.DivergedError.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "engine/input_error.h"
#include "engine/mill_monitor.h"
#include "engine/scene.h"
#include "engine/scene_loader.h"
#include "engine/world.h"

namespace py = pybind11;

namespace {

static_assert(sizeof(dem::Vec3) == 3 * sizeof(double), "numpy views need Vec3 as three packed doubles");

struct PyWorld {
  dem::Scene scene;
  std::unique_ptr<dem::World> world;
};

dem::World& live(PyWorld& w) { return *w.world; }

std::string hex(std::uint64_t v) {
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(v));
  return text;
}

/// A read-only numpy view of `count` items of `item_bytes` each, `cols` per row when cols > 0
/// (N x cols), at `data`, kept alive by `owner`.
template <typename T>
py::array view(const T* data, std::size_t count, std::size_t cols, py::handle owner) {
  std::vector<py::ssize_t> shape{static_cast<py::ssize_t>(count)};
  std::vector<py::ssize_t> strides{static_cast<py::ssize_t>(sizeof(T) * (cols > 0 ? cols : 1))};
  if (cols > 0) {
    shape.push_back(static_cast<py::ssize_t>(cols));
    strides.push_back(static_cast<py::ssize_t>(sizeof(T)));
  }
  // An empty state has no buffer: numpy then makes an empty array of its own.
  py::array a(py::dtype::of<T>(), shape, strides, count > 0 ? data : nullptr, count > 0 ? owner : py::handle());
  py::setattr(a.attr("flags"), "writeable", py::bool_(false));
  return a;
}

py::array vec3_view(const std::vector<dem::Vec3>& v, py::handle owner) {
  return view<double>(v.empty() ? nullptr : v.front().data(), v.size(), 3, owner);
}

dem::Vec3 to_vec3(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }

py::array_t<double> vec3_copy(const std::vector<dem::Vec3>& v) {
  py::array_t<double> a({static_cast<py::ssize_t>(v.size()), py::ssize_t{3}});
  auto m = a.mutable_unchecked<2>();
  for (std::size_t k = 0; k < v.size(); ++k)
    for (int d = 0; d < 3; ++d) m(static_cast<py::ssize_t>(k), d) = v[k][d];
  return a;
}

py::array_t<double> vec3_array(const dem::Vec3& v) {
  py::array_t<double> a(3);
  for (int d = 0; d < 3; ++d) a.mutable_at(d) = v[d];
  return a;
}

std::unique_ptr<PyWorld> from_scene(dem::Scene scene) {
  auto w = std::make_unique<PyWorld>();
  w->world = std::make_unique<dem::World>(scene.world);
  w->scene = std::move(scene);
  return w;
}

/// Runs `advance` with the GIL released (the World's loops never touch Python); a non-ok status
/// raises DivergedError.
void check_status(dem::StepStatus status, const dem::World& world) {
  if (status != dem::StepStatus::ok) {
    char text[128];
    std::snprintf(text, sizeof text, "the run diverged at t = %.9g s (non-finite state)", world.time());
    PyErr_SetString(py::module_::import("dem._core").attr("DivergedError").ptr(), text);
    throw py::error_already_set();
  }
}

struct DivergedTag {};

struct PyMillMonitor {
  std::unique_ptr<dem::MillMonitor> monitor;
};

py::dict revolution_dict(const dem::MillRevolution& r) {
  py::dict d;
  d["index"] = r.index;
  d["start"] = r.start;
  d["end"] = r.end;
  d["torque"] = r.torque;
  d["power_draw"] = r.power_draw;
  d["steady"] = r.steady;
  d["drive_work"] = r.drive_work;
  return d;
}

}  // namespace

PYBIND11_MODULE(_core, m) {
  m.doc() = "dem: the discrete element engine's World, driven from Python (docs/python.md).";
  py::register_exception<dem::InputError>(m, "InputError", PyExc_ValueError);
  // Raised by check_status, which finds it by name in this module.
  py::exception<DivergedTag>(m, "DivergedError", PyExc_RuntimeError);

  py::class_<PyWorld>(m, "World", R"doc(
A discrete element world: particles, walls, contacts and the clock, advanced one sync interval at a time.

Build it with World.from_scene(path) or World.from_toml(text). State arrays (positions, velocities,
angular_velocities, radii, ids, levels) are read-only numpy VIEWS of the World's memory in storage
order (`ids` maps slot to id; slots are in id order unless the scene sets broadphase.sort_interval,
which re-sorts them in space: find a particle by index_of(id)). A view stays valid, and shows the current
values, until the next call that adds or removes a particle (add_particle, remove_particle, or a
callback doing so); advancing (advance, run_until) moves the values in place. Fetch views again after
adding or removing: an old view may then point at freed memory.)doc")
      .def_static(
          "from_scene",
          [](const std::string& path, const std::vector<std::string>& overrides) {
            return from_scene(dem::load_scene(path, overrides));
          },
          py::arg("path"), py::arg("overrides") = std::vector<std::string>{},
          R"doc(Loads a scene file (TOML) as `dem run` does. `overrides` are the `--set key.path=value`
strings of `dem run` (e.g. ["integrator.dt=1e-5", "run.threads=2"]). Raises dem.InputError with the
loader's message (file:line:column: 'field': what is wrong) for a bad scene.)doc")
      .def_static(
          "from_toml",
          [](const std::string& text, const std::string& base_dir, const std::vector<std::string>& overrides,
             const std::string& name) { return from_scene(dem::load_scene_text(text, name, base_dir, overrides)); },
          py::arg("text"), py::arg("base_dir") = ".", py::arg("overrides") = std::vector<std::string>{},
          py::arg("name") = "<string>",
          R"doc(Builds a world from scene TOML text. `base_dir` resolves relative paths (particle files,
meshes); `name` names the text in error messages.)doc")
      .def_property_readonly("time", [](PyWorld& w) { return live(w).time(); }, "Current sync time [s].")
      .def_property_readonly("sync_interval", [](PyWorld& w) { return live(w).sync_interval(); },
                             "Time between sync times [s].")
      .def_property_readonly("particle_count", [](PyWorld& w) { return live(w).particle_count(); },
                             "Particles now in the world.")
      .def_property_readonly("thread_count", [](PyWorld& w) { return live(w).thread_count(); })
      .def_property_readonly("scene_name", [](PyWorld& w) { return w.scene.name; })
      .def_property_readonly("scene_until", [](PyWorld& w) { return w.scene.run.until; },
                             "The scene's [run] until: the end time `dem run` uses without --until [s].")
      .def_property_readonly("dimension", [](PyWorld& w) { return live(w).config().model.dimension; })
      .def_property_readonly("has_mill", [](PyWorld& w) { return w.scene.mill.has_value(); })
      .def(
          "advance",
          [](PyWorld& w) {
            dem::StepStatus s;
            {
              py::gil_scoped_release release;
              s = live(w).advance_sync_interval();
            }
            check_status(s, live(w));
          },
          "Advances every particle to the next sync time. Raises dem.DivergedError on a non-finite state.")
      .def(
          "run_until",
          [](py::object self, double t, py::object callback) {
            PyWorld& w = self.cast<PyWorld&>();
            dem::World::SyncCallback on_sync;
            std::optional<py::error_already_set> pending;
            if (!callback.is_none()) {
              on_sync = [&](dem::World&) {
                py::gil_scoped_acquire acquire;
                try {
                  // Only False stops: a callback returning a value for its own use (a list, 0) runs on.
                  return callback(self).ptr() != Py_False;
                } catch (py::error_already_set& e) {
                  pending.emplace(std::move(e));
                  return false;
                }
              };
            }
            dem::StepStatus s;
            {
              py::gil_scoped_release release;
              s = live(w).run_until(t, on_sync);
            }
            if (pending) throw std::move(*pending);
            check_status(s, live(w));
          },
          py::arg("t"), py::arg("callback") = py::none(),
          R"doc(Advances one sync interval at a time until the first sync time at or after `t` [s], calling
`callback(world)` after every interval (not before the first). The callback may read the world and
add or remove particles; returning False stops the run there (any other value continues). An exception
in the callback stops the run and propagates. Raises dem.DivergedError on a non-finite state.)doc")
      // ---- state views --------------------------------------------------------------------------------
      .def_property_readonly(
          "positions", [](py::object self) { return vec3_view(live(self.cast<PyWorld&>()).state().position, self); },
          "N x 3 float64 view of the positions [m], storage order.")
      .def_property_readonly(
          "velocities", [](py::object self) { return vec3_view(live(self.cast<PyWorld&>()).state().velocity, self); },
          "N x 3 float64 view of the velocities [m/s], storage order.")
      .def_property_readonly(
          "angular_velocities",
          [](py::object self) { return vec3_view(live(self.cast<PyWorld&>()).state().angular_velocity, self); },
          "N x 3 float64 view of the angular velocities [rad/s], storage order.")
      .def_property_readonly(
          "radii",
          [](py::object self) {
            const auto& r = live(self.cast<PyWorld&>()).state().radius;
            return view<double>(r.data(), r.size(), 0, self);
          },
          "N float64 view of the radii [m], storage order.")
      .def_property_readonly(
          "ids",
          [](py::object self) {
            const auto& id = live(self.cast<PyWorld&>()).state().id;
            return view<dem::ParticleId>(id.data(), id.size(), 0, self);
          },
          "N uint32 view of the stable particle ids, in storage order.")
      .def_property_readonly(
          "levels",
          [](py::object self) {
            const auto& l = live(self.cast<PyWorld&>()).state().level;
            return view<std::int8_t>(l.data(), l.size(), 0, self);
          },
          "N int8 view of the step levels (step = dt_base 2^level; 0 under the fixed control), storage order.")
      .def(
          "index_of",
          [](PyWorld& w, dem::ParticleId id) -> std::optional<std::size_t> {
            const auto slot = live(w).index_of(id);
            if (!slot) return std::nullopt;
            return static_cast<std::size_t>(*slot);
          },
          py::arg("id"), "Storage slot of a particle id, or None for an id never given or removed.")
      .def(
          "position", [](PyWorld& w, dem::ParticleId id) { return vec3_array(live(w).position(id)); }, py::arg("id"),
          "Position of a live particle by id (a copy) [m]; IndexError for an id not in the world.")
      .def(
          "velocity", [](PyWorld& w, dem::ParticleId id) { return vec3_array(live(w).velocity(id)); }, py::arg("id"),
          "Velocity of a live particle by id (a copy) [m/s].")
      // ---- energies, walls, contacts ------------------------------------------------------------------
      .def(
          "energies",
          [](PyWorld& w) {
            const dem::World& world = live(w);
            const dem::Energies e = world.energies();
            const dem::EnergyBalance b = world.energy_balance();
            py::dict d;
            d["kinetic"] = e.kinetic;
            d["rotational"] = e.rotational;
            d["potential"] = e.potential;
            d["elastic"] = e.elastic;
            d["total"] = e.total();
            d["dissipated"] = world.dissipated_energy();
            d["wall_work"] = world.wall_work();
            d["removed"] = world.removed_energy();
            d["given"] = world.given_energy();
            d["balance_error"] = b.error;
            d["balance_scale"] = b.scale;
            return d;
          },
          R"doc(Energies [J] as a dict: kinetic, rotational, potential (gravity, relative to the origin),
elastic (contact springs), total (their sum), dissipated (by contacts since the start), wall_work (of
the moving walls on the particles), removed (carried out by removed particles), balance_error
((E - E0) + dissipated - wall_work + removed; ~0 for a sound run) and balance_scale (energy in play).)doc")
      .def_property_readonly(
          "wall_names",
          [](PyWorld& w) {
            std::vector<std::string> names;
            for (std::size_t k = 0; k < live(w).walls().count(); ++k) names.push_back(live(w).walls().config(k).name);
            return names;
          },
          "Names of the walls, in wall index order.")
      .def(
          "wall_loads",
          [](PyWorld& w) {
            const std::vector<dem::WallLoad> loads = live(w).wall_loads();
            std::vector<dem::Vec3> f, t;
            for (const dem::WallLoad& l : loads) {
              f.push_back(l.force);
              t.push_back(l.torque);
            }
            return py::make_tuple(vec3_copy(f), vec3_copy(t));
          },
          R"doc((force, torque): W x 3 arrays (copies) of the force [N] and the torque about each wall's
rotation centre [N m] of the particles on each wall at the last evaluation.)doc")
      .def(
          "wall_angular_velocities",
          [](PyWorld& w) {
            std::vector<dem::Vec3> v;
            for (std::size_t k = 0; k < live(w).walls().count(); ++k) v.push_back(live(w).walls().angular_velocity(k));
            return vec3_copy(v);
          },
          "W x 3 array of each wall's angular velocity now [rad/s].")
      .def(
          "contact_forces",
          [](PyWorld& w) {
            const std::vector<dem::ContactForce> c = live(w).contact_forces();
            const auto n = static_cast<py::ssize_t>(c.size());
            py::array_t<dem::ParticleId> i(n), j(n);
            py::array_t<int> wall(n);
            py::array_t<double> overlap(n);
            std::vector<dem::Vec3> force, point;
            for (py::ssize_t k = 0; k < n; ++k) {
              const dem::ContactForce& f = c[static_cast<std::size_t>(k)];
              i.mutable_at(k) = f.particle;
              j.mutable_at(k) = f.partner;
              wall.mutable_at(k) = f.wall;
              overlap.mutable_at(k) = f.overlap;
              force.push_back(f.force);
              point.push_back(f.point);
            }
            py::dict d;
            d["i"] = i;
            d["j"] = j;
            d["wall"] = wall;
            d["force"] = vec3_copy(force);
            d["point"] = vec3_copy(point);
            d["overlap"] = overlap;
            return d;
          },
          R"doc(Every pair and wall contact of the last force evaluation (copies), as a dict of arrays:
i, j (uint32 ids; pairs: i < j; walls: j == i), wall (wall index, -1 for a pair), force (K x 3, on
particle i; the partner or wall gets the negative) [N], point (K x 3) [m], overlap [m]. Pairs first
in ascending id pairs, then wall contacts.)doc")
      .def(
          "state_hash", [](PyWorld& w) { return hex(live(w).state_hash()); },
          "Hash of the full state as 16 hex digits: the state_hash `dem run` prints and writes to summary.json.")
      // ---- feeding and discharging ---------------------------------------------------------------------
      .def(
          "is_free",
          [](PyWorld& w, const std::array<double, 3>& x, double r) { return live(w).is_free(to_vec3(x), r); },
          py::arg("position"), py::arg("radius"),
          "True when a sphere of `radius` at `position` would touch no particle and no wall.")
      .def(
          "add_particle",
          [](PyWorld& w, const std::array<double, 3>& x, double r, const std::array<double, 3>& v,
             const std::array<double, 3>& omega, const std::string& material, double mass, double density) {
            dem::ParticleConfig p;
            p.position = to_vec3(x);
            p.velocity = to_vec3(v);
            p.angular_velocity = to_vec3(omega);
            p.radius = r;
            p.material = material;
            p.mass = mass;
            p.density = density;
            return live(w).add_particle(p);
          },
          py::arg("position"), py::arg("radius"), py::arg("velocity") = std::array<double, 3>{0, 0, 0},
          py::arg("angular_velocity") = std::array<double, 3>{0, 0, 0}, py::arg("material") = "default",
          py::arg("mass") = 0.0, py::arg("density") = 0.0,
          R"doc(Adds a particle at the current sync time (between sync intervals: before a run or in a
run_until callback) and returns its new id: one past the largest id ever given (ids are never
reused). It takes the next storage slot (the last). mass 0: from the density; density 0: the
material's. Raises ValueError when it overlaps a particle or wall (see is_free), names an unknown
material, or has a bad radius or state. Invalidates earlier views.)doc")
      .def(
          "remove_particle", [](PyWorld& w, dem::ParticleId id) { return live(w).remove_particle(id); }, py::arg("id"),
          R"doc(Removes a particle by id at the current sync time; returns False (and changes nothing) for an
id never given or already removed. Later slots move down by one. Its kinetic, rotational and spring
energy is booked as energies()["removed"]. Invalidates earlier views.)doc")
      .def(
          "set_velocity",
          [](PyWorld& w, dem::ParticleId id, const std::array<double, 3>& v) {
            return live(w).set_velocity(id, to_vec3(v));
          },
          py::arg("id"), py::arg("velocity"),
          R"doc(Sets a particle's velocity [m/s] at the current sync time, as an impulse: position, spin and
contacts stay. Returns False (and changes nothing) for an id never given or removed, a non-finite
velocity, or a z component in 2D. The kinetic energy it adds is booked as energies()["given"].)doc");

  py::class_<PyMillMonitor>(m, "MillMonitor", R"doc(
Measures a running mill from the scene's [mill] section, as `dem run` does (engine/mill_monitor.h):
drive power from the work the mill's walls do on the charge, per revolution, and the mean over the
steady revolutions (summary.json's mean_power_draw). Call observe(world) at every sync time.)doc")
      .def(py::init([](PyWorld& w) {
             if (!w.scene.mill) throw std::invalid_argument("no [mill] section in " + w.scene.file);
             return PyMillMonitor{std::make_unique<dem::MillMonitor>(*w.scene.mill, live(w))};
           }),
           py::arg("world"), "Starts counting at the world's time.")
      .def(
          "observe",
          [](PyMillMonitor& mm, PyWorld& w) {
            py::list out;
            for (const dem::MillRevolution& r : mm.monitor->observe(live(w))) out.append(revolution_dict(r));
            return out;
          },
          py::arg("world"),
          R"doc(Call at every sync time: closes the revolutions completed since the last call and returns
them as dicts (index, start, end [s], torque [N m], power_draw [W], steady, drive_work [J]).)doc")
      .def_property_readonly("revolutions",
                             [](PyMillMonitor& mm) {
                               py::list out;
                               for (const dem::MillRevolution& r : mm.monitor->revolutions())
                                 out.append(revolution_dict(r));
                               return out;
                             })
      .def_property_readonly(
          "mean_power_draw", [](PyMillMonitor& mm) { return mm.monitor->mean_power_draw(); },
          "Mean drive power over the steady revolutions [W]; None before one completes.")
      .def_property_readonly("mean_torque", [](PyMillMonitor& mm) { return mm.monitor->mean_torque(); })
      .def_property_readonly("steady_revolutions", [](PyMillMonitor& mm) { return mm.monitor->steady_revolutions(); });
}
