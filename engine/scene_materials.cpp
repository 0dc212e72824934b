// Scene sections [[materials]] and [[contacts]] (with their damping tables).
#include "engine/scene_sections.h"

#include <utility>

#include "engine/particle_csv.h"

namespace dem::loader {

Damping read_damping(TableReader& r, const std::string& key, bool allow_restitution) {
  const toml::table* t = r.table(key);
  if (!t) return Damping{};
  TableReader d(*t, r.field(key), r.file());
  const std::vector<std::pair<std::string, DampingKind>> kinds = {
      {"restitution", DampingKind::restitution}, {"damping_ratio", DampingKind::damping_ratio},
      {"coefficient", DampingKind::coefficient}, {"tsuji_alpha", DampingKind::tsuji_alpha},
      {"gamma", DampingKind::gamma}};
  Damping out;
  int given = 0;
  // Restitution is no key of a tangential damping: rejected with its reason, not as unknown.
  if (!allow_restitution && d.contains("restitution"))
    d.fail("restitution", "restitution is only defined for the normal damping; here give damping_ratio, coefficient "
                          "[N s/m], tsuji_alpha or gamma [1/s]");
  for (const auto& [name, kind] : kinds) {
    if (kind == DampingKind::restitution && !allow_restitution) continue;
    if (!d.has(name)) continue;
    ++given;
    out.kind = kind;
    out.value = d.non_negative(name, 0);
    if (kind == DampingKind::restitution) {
      if (!(out.value > 0 && out.value <= 1)) d.fail(name, "restitution must be in (0, 1], got " + TableReader::number(out.value));
    }
  }
  d.finish();
  if (given != 1)
    r.fail(key, "give exactly one of restitution, damping_ratio, coefficient [N s/m], tsuji_alpha, gamma [1/s]");
  return out;
}

void read_materials(TableReader& top, Scene& scene) {
  const auto tables = top.tables("materials");
  if (tables.empty()) return;  // keep the built-in "default" material
  scene.world.materials.clear();
  for (std::size_t i = 0; i < tables.size(); ++i) {
    TableReader r(*tables[i], indexed("materials", i), top.file());
    MaterialConfig m;
    m.name = r.string("name", "");
    if (m.name.empty()) r.fail("name", "every material needs a non-empty name");
    if (!fits_csv_cell(m.name))
      r.fail("name", "'" + m.name + "': a material name may not hold a comma, quote or line break, nor start or end "
                     "with a space or tab (particle files name materials in a CSV column)");
    for (const auto& other : scene.world.materials)
      if (other.name == m.name) r.fail("name", "material '" + m.name + "' is defined twice");
    m.density = r.required_positive("density");
    r.finish();
    scene.world.materials.push_back(m);
  }
}

bool known_material(const Scene& scene, const std::string& name) {
  for (const auto& m : scene.world.materials)
    if (m.name == name) return true;
  return false;
}

std::string material_names(const Scene& scene) {
  std::vector<std::string> names;
  for (const auto& m : scene.world.materials) names.push_back(m.name);
  return join(names);
}

std::string read_material_name(TableReader& r, const Scene& scene, const std::string& key) {
  const std::string fallback = scene.world.materials.front().name;
  const std::string name = r.string(key, fallback);
  if (!known_material(scene, name)) r.fail(key, "unknown material '" + name + "'; defined: " + material_names(scene));
  return name;
}

void read_contacts(TableReader& top, Scene& scene) {
  const auto tables = top.tables("contacts");
  if (tables.empty()) top.fail("contacts", "at least one [[contacts]] table is required (normal_stiffness at least)");
  scene.world.contacts.clear();
  for (std::size_t i = 0; i < tables.size(); ++i) {
    TableReader r(*tables[i], indexed("contacts", i), top.file());
    ContactConfig c;
    if (const toml::node* n = r.node("materials")) {
      const toml::array* a = n->as_array();
      if (!a || a->size() != 2 || !a->get(0)->is_string() || !a->get(1)->is_string())
        r.fail("materials", "expected two material names, e.g. [\"steel\", \"steel\"]");
      c.material_a = *a->get(0)->value<std::string>();
      c.material_b = *a->get(1)->value<std::string>();
      for (const auto& name : {c.material_a, c.material_b})
        if (!known_material(scene, name)) r.fail("materials", "unknown material '" + name + "'; defined: " + material_names(scene));
    }
    c.normal_stiffness = r.required_positive("normal_stiffness");
    c.normal_damping = read_damping(r, "normal_damping", true);
    if (r.has("tangential_stiffness")) c.tangential_stiffness = r.positive("tangential_stiffness", 1);
    c.tangential_damping = read_damping(r, "tangential_damping", false);
    c.sliding_friction = r.non_negative("sliding_friction", 0);
    c.static_friction = r.has("static_friction") ? r.non_negative("static_friction", 0) : c.sliding_friction;
    if (c.static_friction < c.sliding_friction)
      r.fail("static_friction", "must be >= sliding_friction (" + TableReader::number(c.sliding_friction) + ")");
    c.rolling_friction = r.non_negative("rolling_friction", 0);
    c.rolling_static_friction =
        r.has("rolling_static_friction") ? r.non_negative("rolling_static_friction", 0) : c.rolling_friction;
    if (r.has("rolling_stiffness")) c.rolling_stiffness = r.positive("rolling_stiffness", 1);
    r.finish();
    scene.world.contacts.push_back(c);
  }
}

}  // namespace dem::loader
