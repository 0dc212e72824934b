// Scene sections [scene], [integrator], [run], [output], [broadphase] and [accuracy].
#include "engine/scene_sections.h"

#include <algorithm>

namespace dem::loader {

void read_model(TableReader& r, Scene& scene) {
  ModelConfig& m = scene.world.model;
  scene.name = r.string("name", scene.name);
  const int dim = r.integer("dimension", 3);
  if (dim != 2 && dim != 3) r.fail("dimension", "must be 2 (discs in the xy plane) or 3 (spheres)");
  m.dimension = dim;
  m.thickness = r.positive("thickness", 1);
  m.gravity = r.vec3("gravity", Vec3::Zero());
  if (dim == 2 && m.gravity.z() != 0) r.fail("gravity", "a 2D scene lives in the xy plane: the z component must be 0");
  m.separation = r.choice("separation", {"force_zero", "overlap"}, 0) == 0 ? Separation::force_zero : Separation::overlap;
  m.rolling_mode = r.choice("rolling_mode", {"standard", "seed"}, 0) == 0 ? RollingMode::standard : RollingMode::seed;
  scene.max_initial_overlap = r.non_negative("max_initial_overlap", 0.01);
}

/// Returns whether the scene sets level_max.
bool read_integrator(TableReader& top, Scene& scene) {
  IntegratorConfig& c = scene.world.integrator;
  const toml::table* t = top.table("integrator");
  if (!t) top.fail("integrator", "an [integrator] table with at least dt [s] is required");
  const bool level_max_given = t->contains("level_max");
  TableReader r(*t, "integrator", top.file());
  c.method = r.choice("method", {"verlet", "exact"}, 0) == 0 ? Method::verlet : Method::exact;
  c.control = r.choice("control", {"fixed", "doubling"}, 0) == 0 ? Control::fixed : Control::doubling;
  c.dt = r.required_positive("dt");
  c.dt_base = r.positive("dt_base", c.dt);
  c.tolerance = r.positive("tolerance", c.tolerance);
  c.level_min = r.integer("level_min", c.level_min);
  c.level_max = r.integer("level_max", c.level_max);
  if (c.level_min > c.level_max) r.fail("level_min", "must be <= level_max");
  if (c.level_max - c.level_min > 40) r.fail("level_max", "level_max - level_min must be at most 40");
  if (c.level_min < -100) r.fail("level_min", "must be >= -100 (steps of dt_base * 2^-100 and finer are meaningless)");
  if (c.level_max > 100) r.fail("level_max", "must be <= 100");
  c.safety = r.positive("safety", c.safety);
  if (c.safety >= 1) r.fail("safety", "must be in (0, 1)");
  c.velocity_weight = r.non_negative("velocity_weight", c.velocity_weight);
  c.dx_min = r.positive("dx_min", c.dx_min);
  c.richardson = r.boolean("richardson", c.richardson);
  c.error_per_unit_step = r.boolean("error_per_unit_step", c.error_per_unit_step);
  c.predicted_dashpot = r.boolean("predicted_dashpot", c.predicted_dashpot);
  c.particle_levels = r.boolean("particle_levels", c.particle_levels);
  if (c.particle_levels && c.method == Method::exact)
    r.fail("particle_levels", "needs method = \"verlet\": the exact stepper keeps one level per touching set (a "
                              "pair's flow needs both sides live)");
  if (c.particle_levels && c.predicted_dashpot)
    r.fail("particle_levels", "does not combine with predicted_dashpot yet: set one of them to false");
  r.finish();
  return level_max_given;
}

void read_run_and_output(TableReader& top, Scene& scene) {
  if (const toml::table* t = top.table("run")) {
    TableReader r(*t, "run", top.file());
    scene.run.until = r.positive("until", scene.run.until);
    scene.world.threads = r.integer("threads", 0);
    if (scene.world.threads < 0) r.fail("threads", "must be >= 0 (0: every core of the affinity mask)");
    if (r.has("stop_kinetic_energy")) scene.run.stop_kinetic_energy = r.positive("stop_kinetic_energy", 1);
    scene.run.stop_check_after = r.non_negative("stop_check_after", 0);
    r.finish();
  }
  if (const toml::table* t = top.table("output")) {
    TableReader r(*t, "output", top.file());
    scene.output.interval = r.positive("interval", scene.output.interval);
    scene.output.snapshot_interval = r.non_negative("snapshot_interval", scene.output.interval);
    scene.output.settled_file = r.string("settled_file", "");
    scene.output.trajectories = r.boolean("trajectories", false);
    scene.output.contacts = r.boolean("contacts", false);
    scene.output.vtk_ascii = r.choice("vtk_format", {"binary", "ascii"}, 0) == 1;
    r.finish();
  }
  if (scene.output.snapshot_interval < 0) scene.output.snapshot_interval = scene.output.interval;
  if (const toml::table* t = top.table("broadphase")) {
    TableReader r(*t, "broadphase", top.file());
    if (r.has("skin")) scene.world.broadphase.skin = r.non_negative("skin", 0);
    scene.world.broadphase.use_kd_tree = r.choice("kind", {"grid", "kd_tree"}, 0) == 1;
    scene.world.broadphase.wall_lists = r.boolean("wall_lists", true);
    const int sort_interval = r.integer("sort_interval", scene.world.broadphase.sort_interval);
    if (sort_interval < 0) r.fail("sort_interval", "must be a number of steps >= 0 (0: never re-sort), got " +
                                                       std::to_string(sort_interval));
    scene.world.broadphase.sort_interval = sort_interval;
    r.finish();
  }
}

/// [accuracy]: the metrics `dem trade` measures, each a name of accuracy_metric_names, at most once.
void read_accuracy(TableReader& top, Scene& scene) {
  const toml::table* t = top.table("accuracy");
  if (!t) return;
  TableReader r(*t, "accuracy", top.file());
  const std::vector<std::string> valid(accuracy_metric_names.begin(), accuracy_metric_names.end());
  if (const toml::node* node = r.node("metrics")) {
    const toml::array* a = node->as_array();
    if (!a || a->empty()) r.fail("metrics", "expected a non-empty array of metric names from: " + join(valid));
    for (const toml::node& e : *a) {
      const toml::node* where = e.source().begin.line == 0 ? node : &e;
      const auto name = e.value_exact<std::string>();
      if (!name) r.fail_at(where, "metrics", "expected metric names (strings) from: " + join(valid));
      if (std::find(valid.begin(), valid.end(), *name) == valid.end())
        r.fail_at(where, "metrics", "unknown metric '" + *name + "'; valid metrics: " + join(valid));
      if (std::find(scene.accuracy.metrics.begin(), scene.accuracy.metrics.end(), *name) != scene.accuracy.metrics.end())
        r.fail_at(where, "metrics", "metric '" + *name + "' is listed twice");
      scene.accuracy.metrics.push_back(*name);
    }
  }
  r.finish();
}

}  // namespace dem::loader
