// The schema of scene files: every key with its unit, and the recorder of keys asked for.
#include "engine/scene_schema.h"

namespace dem {
namespace {

// Every key a scene may hold (scene_keys()), with its unit as scenes/README.md writes it ("–" a
// dimensionless number, "" no unit). The table readers ask only for these; scenes/README.md
// documents each with the same unit (tests/scene_loader_test.cpp holds the three together), and
// messages about a value name its unit.
const std::vector<SceneKey> schema = {
    // top level
    {"scene", ""}, {"materials", ""}, {"contacts", ""}, {"walls", ""}, {"particles", ""}, {"particle_files", ""},
    {"generators", ""}, {"mill", ""}, {"integrator", ""}, {"run", ""}, {"output", ""}, {"broadphase", ""},
    {"accuracy", ""},
    // [scene]
    {"scene.name", ""}, {"scene.dimension", ""}, {"scene.thickness", "m"}, {"scene.gravity", "m/s²"},
    {"scene.separation", ""}, {"scene.rolling_mode", ""}, {"scene.max_initial_overlap", "–"},
    // [[materials]]
    {"materials.name", ""}, {"materials.density", "kg/m³"},
    // [[contacts]]
    {"contacts.materials", ""}, {"contacts.normal_stiffness", "N/m"}, {"contacts.normal_damping", ""},
    {"contacts.tangential_stiffness", "N/m"}, {"contacts.tangential_damping", ""},
    {"contacts.sliding_friction", "–"}, {"contacts.static_friction", "–"}, {"contacts.rolling_friction", "–"},
    {"contacts.rolling_static_friction", "–"}, {"contacts.rolling_stiffness", "N m/rad"},
    {"contacts.normal_damping.restitution", "–"}, {"contacts.normal_damping.damping_ratio", "–"},
    {"contacts.normal_damping.coefficient", "N s/m"}, {"contacts.normal_damping.tsuji_alpha", "–"},
    {"contacts.normal_damping.gamma", "1/s"}, {"contacts.tangential_damping.damping_ratio", "–"},
    {"contacts.tangential_damping.coefficient", "N s/m"}, {"contacts.tangential_damping.tsuji_alpha", "–"},
    {"contacts.tangential_damping.gamma", "1/s"},
    // [[walls]]
    {"walls.name", ""}, {"walls.type", ""}, {"walls.material", ""}, {"walls.point", "m"}, {"walls.normal", "–"},
    {"walls.half_extents", "m"}, {"walls.inside", ""}, {"walls.axis", "–"}, {"walls.radius", "m"},
    {"walls.length", "m"}, {"walls.profile", "m"}, {"walls.file", ""}, {"walls.scale", "m per file unit"},
    {"walls.velocity", "m/s"}, {"walls.angular_velocity", "rad/s"}, {"walls.rotation_center", "m"},
    {"walls.ramp_time", "s"},
    // [[particles]], [[particle_files]], [[generators]]
    {"particles.position", "m"}, {"particles.velocity", "m/s"}, {"particles.angular_velocity", "rad/s"},
    {"particles.radius", "m"}, {"particles.mass", "kg"}, {"particles.density", "kg/m³"}, {"particles.material", ""},
    {"particle_files.file", ""}, {"particle_files.material", ""}, {"particle_files.offset", "m"},
    {"generators.count", ""}, {"generators.seed", ""}, {"generators.material", ""}, {"generators.velocity", "m/s"},
    {"generators.max_attempts", ""}, {"generators.region", ""}, {"generators.size", ""},
    {"generators.region.type", ""}, {"generators.region.min", "m"}, {"generators.region.max", "m"},
    {"generators.region.center", "m"}, {"generators.region.axis", "–"}, {"generators.region.radius", "m"},
    {"generators.region.length", "m"}, {"generators.size.distribution", ""}, {"generators.size.radius", "m"},
    {"generators.size.min", "m"}, {"generators.size.max", "m"}, {"generators.size.mean", "m"},
    {"generators.size.std", "m"}, {"generators.size.median", "m"}, {"generators.size.sigma", "–"},
    // [mill]
    {"mill.diameter", "m"}, {"mill.length", "m"}, {"mill.lifters", ""}, {"mill.lifter_height", "m"},
    {"mill.lifter_width", "m"}, {"mill.lifter_face_angle", "degrees"}, {"mill.rpm", "rpm"},
    {"mill.critical_fraction", "–"}, {"mill.direction", ""}, {"mill.ramp_time", "s"},
    {"mill.discard_revolutions", ""}, {"mill.material", ""}, {"mill.size_classes", "m"}, {"mill.charge", ""}, {"mill.charge.count", ""},
    {"mill.charge.filling", "–"}, {"mill.charge.solids_fraction", "–"}, {"mill.charge.size", ""},
    {"mill.charge.material", ""}, {"mill.charge.seed", ""}, {"mill.charge.max_attempts", ""},
    {"mill.charge.size.distribution", ""}, {"mill.charge.size.radius", "m"}, {"mill.charge.size.min", "m"},
    {"mill.charge.size.max", "m"}, {"mill.charge.size.mean", "m"}, {"mill.charge.size.std", "m"},
    {"mill.charge.size.median", "m"}, {"mill.charge.size.sigma", "–"},
    // [integrator]
    {"integrator.method", ""}, {"integrator.control", ""}, {"integrator.dt", "s"}, {"integrator.dt_base", "s"},
    {"integrator.tolerance", "–"}, {"integrator.level_min", ""}, {"integrator.level_max", ""},
    {"integrator.safety", "–"}, {"integrator.velocity_weight", "–"}, {"integrator.dx_min", "–"},
    {"integrator.richardson", ""}, {"integrator.error_per_unit_step", ""}, {"integrator.predicted_dashpot", ""},
    {"integrator.particle_levels", ""},
    // [run], [output], [broadphase], [accuracy]
    {"run.until", "s"}, {"run.threads", ""}, {"run.stop_kinetic_energy", "J"}, {"run.stop_check_after", "s"},
    {"output.interval", "s"}, {"output.snapshot_interval", "s"}, {"output.settled_file", ""},
    {"output.trajectories", ""}, {"output.contacts", ""}, {"output.vtk_format", ""},
    {"broadphase.skin", "m"}, {"broadphase.kind", ""}, {"broadphase.wall_lists", ""},
    {"broadphase.sort_interval", ""},
    {"accuracy.metrics", ""}};


// The recorder of this thread, if any (SceneKeyRecorder).
thread_local std::set<std::string>* key_recorder = nullptr;

}  // namespace

const std::vector<SceneKey>& scene_keys() { return schema; }

const SceneKey* find_scene_key(const std::string& path) {
  for (const SceneKey& k : schema)
    if (k.path == path) return &k;
  return nullptr;
}

SceneKeyRecorder::SceneKeyRecorder() : previous_(key_recorder) { key_recorder = &keys_; }
SceneKeyRecorder::~SceneKeyRecorder() { key_recorder = previous_; }

void record_scene_key(const std::string& path) {
  if (key_recorder) key_recorder->insert(path);
}

}  // namespace dem
