// Scene section [mill]: the mill's walls and its charge.
#include "engine/scene_sections.h"

#include <cmath>

#include "engine/collision_spectra.h"
#include "engine/mill.h"
#include "engine/particle_generator.h"

namespace dem::loader {

/// mill.size_classes: the radius edges [m] that split the collision spectra's events by kind.
std::vector<double> read_size_classes(TableReader& r) {
  std::vector<double> edges;
  const std::string key = "size_classes";
  if (!r.has(key)) return edges;
  const std::string what = "must be an array of radii [m], positive and strictly ascending, that separate the size "
                           "classes (e.g. [0.002]: below 2 mm and from 2 mm up)";
  const toml::node* node = r.node(key);
  const toml::array* a = node->as_array();
  if (!a || a->empty()) r.fail(key, what + (a ? ", got an empty array" : ""));
  if (a->size() >= static_cast<std::size_t>(CollisionSpectra::max_classes))
    r.fail(key, what + ", at most " + std::to_string(CollisionSpectra::max_classes - 1) + " edges");
  for (const toml::node& e : *a) {
    std::optional<double> v = e.value_exact<double>();
    if (!v) {
      if (auto n = e.value_exact<int64_t>()) v = static_cast<double>(*n);
    }
    const toml::node* at = e.source().begin.line == 0 ? node : &e;
    if (!v) r.fail_at(at, key, what + ", got a value that is not a number");
    if (!(*v > 0) || !std::isfinite(*v)) r.fail_at(at, key, what + ", got " + TableReader::number(*v));
    if (!edges.empty() && !(*v > edges.back()))
      r.fail_at(at, key, what + ", got " + TableReader::number(*v) + " after " + TableReader::number(edges.back()));
    edges.push_back(*v);
  }
  return edges;
}

/// [mill]: the shell, lifters and end walls as prescribed-motion walls, and the charge (engine/mill.h).
void read_mill(TableReader& top, Scene& scene) {
  const toml::table* t = top.table("mill");
  if (!t) return;
  TableReader r(*t, "mill", top.file());
  MillConfig m;
  m.dimension = scene.world.model.dimension;
  m.diameter = r.required_positive("diameter");
  if (m.dimension == 3) m.length = r.required_positive("length");
  m.lifters = r.integer("lifters", 0);
  if (m.lifters < 0 || m.lifters > 360) r.fail("lifters", "must be a number of lifter bars from 0 to 360");
  if (m.lifters > 0) {
    m.lifter_height = r.required_positive("lifter_height");
    if (m.lifter_height >= 0.25 * m.diameter) r.fail("lifter_height", "must be less than a quarter of the diameter");
    m.lifter_width = r.required_positive("lifter_width");
    m.lifter_face_angle = r.non_negative("lifter_face_angle", 0);
    if (m.lifter_face_angle > 60) r.fail("lifter_face_angle", "must be from 0 to 60 degrees");
    const Real base = m.lifter_width + 2 * 1.25 * m.lifter_height * std::tan(m.lifter_face_angle * pi / 180);
    if (m.lifters * base >= pi * m.diameter) r.fail("lifters", "the lifters' bases overlap: fewer, narrower or steeper lifters");
    const Real top_radius = 0.5 * m.diameter - m.lifter_height;
    if (std::atan2(0.5 * m.lifter_width, top_radius) * m.lifters >= pi)
      r.fail("lifter_width", "the lifters' top faces overlap: fewer or narrower lifters");
    if (top_radius * top_radius + 0.25 * m.lifter_width * m.lifter_width >= 0.25 * m.diameter * m.diameter)
      r.fail("lifter_width", "the lifter's top face reaches beyond the shell: narrower or taller lifters");
  } else {
    for (const char* key : {"lifter_height", "lifter_width", "lifter_face_angle"})
      if (r.has(key)) r.fail(key, "has no effect without lifters: set lifters = N or remove it");
  }
  if (scene.world.walls.size() + mill_wall_count(m) > max_walls)
    r.fail("lifters", "the mill's walls and the [[walls]] exceed " + std::to_string(max_walls) + " walls");
  m.direction = r.choice("direction", {"counterclockwise", "clockwise"}, 0) == 0 ? 1 : -1;
  m.ramp_time = r.non_negative("ramp_time", 0);
  m.discard_revolutions = r.integer("discard_revolutions", 2);
  if (m.discard_revolutions < 0) r.fail("discard_revolutions", "must be >= 0");
  m.material = read_material_name(r, scene, "material");
  scene.world.spectra_size_classes = read_size_classes(r);
  const Vec3 g = scene.world.model.gravity;
  if (!(g.norm() > 0) || std::abs(g.z()) > 1e-9 * g.norm())
    top.fail("scene", "a mill turns about the z axis: scene.gravity must be non-zero and in the xy plane");

  // The charge: a generator filling the space inside the lifter tips; it falls into place at the start.
  const toml::table* charge_table = r.table("charge");
  if (!charge_table) r.fail("charge", "is required: { filling = 0.3, size = { radius = ... } } or { count = ..., ... }");
  TableReader c(*charge_table, r.field("charge"), top.file());
  GeneratorConfig charge;
  charge.seed = c.unsigned_integer("seed", 1);
  charge.material = read_material_name(c, scene, "material");
  charge.max_attempts = c.integer("max_attempts", 1000);
  charge.dimension = m.dimension;
  read_size(c, charge);
  const Real mean_radius = radius_moment(charge, 1);
  if (2 * charge.r_max >= mill_free_radius(m)) c.fail("size", "balls must be smaller than the space inside the lifters");
  if (c.has("count") == c.has("filling")) c.fail("count", "give either count (balls) or filling (fraction of the mill volume the charge fills at rest)");
  if (c.has("count")) {
    charge.count = c.integer("count", 0);
    if (charge.count <= 0) c.fail("count", "must be a positive number of balls");
  } else {
    const Real filling = c.positive("filling", 0.3);
    if (filling >= 0.6) c.fail("filling", "must be below 0.6 (a fraction of the mill volume)");
    const Real solids = c.positive("solids_fraction", m.dimension == 3 ? 0.6 : 0.8);
    if (solids >= 1) c.fail("solids_fraction", "must be in (0, 1): the fraction of the charge's bulk volume that is balls");
    const Real R = 0.5 * m.diameter;
    const Real bulk = m.dimension == 3 ? pi * R * R * m.length : pi * R * R;
    const Real ball = m.dimension == 3 ? 4.0 / 3.0 * pi * radius_moment(charge, 3) : pi * radius_moment(charge, 2);
    const Real count = std::round(filling * solids * bulk / ball);
    if (!(count >= 1) || count > 1e8) c.fail("filling", "gives " + TableReader::number(count) + " balls; at least 1 and at most 1e8");
    charge.count = static_cast<int>(count);
  }
  c.finish();
  // Speed: rpm, or a fraction of the critical speed for the mean ball.
  m.critical_speed = critical_speed(m.diameter, 2 * mean_radius, g.norm());
  if (r.has("rpm") == r.has("critical_fraction")) r.fail("rpm", "give either rpm or critical_fraction (of the critical speed)");
  m.speed = r.has("rpm") ? r.positive("rpm", 1) * 2 * pi / 60 : r.positive("critical_fraction", 0.75) * m.critical_speed;
  r.finish();

  charge.region = GeneratorRegion::cylinder;
  charge.center = Vec3::Zero();
  charge.axis = Vec3::UnitZ();
  charge.radius = mill_free_radius(m);
  charge.length = m.dimension == 3 ? m.length : 0;
  const std::size_t before = scene.world.particles.size();
  const GeneratorResult result = generate_particles(charge, scene.world.particles);
  if (!result.ok) c.fail(c.has("count") ? "count" : "filling", "the charge does not fit loosely in the mill: " + result.message);
  for (std::size_t k = before; k < scene.world.particles.size(); ++k) scene.sources.push_back(source_of(*charge_table, top.file(), c.path()));
  scene.seeds.push_back(charge.seed);
  m.first_wall = add_mill_walls(m, scene.world.walls);
  scene.world.collision_spectra = true;
  scene.mill = m;
}

}  // namespace dem::loader
