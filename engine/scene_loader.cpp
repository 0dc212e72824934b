// Reads a TOML scene into a Scene. Each table is read through a TableReader that records the keys it
// consumed; whatever is left over is an unknown key, reported with the closest known one.
#include "engine/scene_loader.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <fstream>
#include <optional>
#include <set>
#include <sstream>

#include <toml++/toml.h>

#include "broadphase/grid.h"
#include "engine/input_error.h"
#include "engine/particle_csv.h"
#include "engine/particle_generator.h"
#include "engine/mill.h"
#include "engine/stl_reader.h"
#include "engine/walls.h"

namespace dem {
namespace {

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

std::string join(const std::vector<std::string>& items) {
  std::string s;
  for (const auto& item : items) s += (s.empty() ? "" : ", ") + item;
  return s;
}

// Every key a scene may hold (scene_keys()), with its unit as scenes/README.md writes it ("–" a
// dimensionless number, "" no unit). The readers below ask only for these; scenes/README.md
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
    {"mill.discard_revolutions", ""}, {"mill.material", ""}, {"mill.charge", ""}, {"mill.charge.count", ""},
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
    // [run], [output], [broadphase], [accuracy]
    {"run.until", "s"}, {"run.threads", ""}, {"run.stop_kinetic_energy", "J"}, {"run.stop_check_after", "s"},
    {"output.interval", "s"}, {"output.snapshot_interval", "s"}, {"output.settled_file", ""},
    {"output.trajectories", ""}, {"output.contacts", ""}, {"output.vtk_format", ""}, {"broadphase.skin", "m"},
    {"broadphase.kind", ""}, {"broadphase.wall_lists", ""},
    {"accuracy.metrics", ""}};

const SceneKey* find_key(const std::string& path) {
  for (const SceneKey& k : schema)
    if (k.path == path) return &k;
  return nullptr;
}

// The recorder of this thread, if any (SceneKeyRecorder).
thread_local std::set<std::string>* key_recorder = nullptr;

/// A table's path without array indices: "contacts[2].normal_damping" -> "contacts.normal_damping".
std::string schema_path(const std::string& path) {
  std::string out;
  for (std::size_t i = 0; i < path.size(); ++i) {
    if (path[i] == '[') {
      i = path.find(']', i);
      if (i == std::string::npos) break;
      continue;
    }
    out += path[i];
  }
  return out;
}

std::string with_unit(const std::string& unit) { return unit.empty() || unit == "–" ? "" : " (" + unit + ")"; }

/// Reads one TOML table: typed getters with defaults and checks, and unknown-key detection.
class TableReader {
 public:
  TableReader(const toml::table& table, std::string path, const std::string& file)
      : table_(table), path_(std::move(path)), file_(file), schema_path_(schema_path(path_)) {}

  std::string field(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

  [[noreturn]] void fail(const std::string& key, const std::string& message) const {
    const toml::node* node = table_.get(key);
    if (!node) {
      // A missing key is often a misspelt one: point at the near miss and name the key wanted.
      if (const auto near = near_miss(key))
        fail_at(near->second, key, message + "; found '" + near->first + "': did you mean '" + key + "'?");
    }
    fail_at(node, key, message);
  }

  /// Like fail, located at `node` (the table itself when null).
  [[noreturn]] void fail_at(const toml::node* node, const std::string& key, const std::string& message) const {
    const toml::source_region& where = node ? node->source() : table_.source();
    throw InputError(file_, static_cast<int>(where.begin.line), static_cast<int>(where.begin.column), field(key),
                     message + (where.begin.line == 0 ? " (set on the command line)" : ""));
  }

  /// The key of this table closest to `key` that no getter has asked for: edit distance 1 for short keys,
  /// up to 3 for long ones (so "max" is not taken for a misspelt "min").
  std::optional<std::pair<std::string, const toml::node*>> near_miss(const std::string& key) const {
    std::optional<std::pair<std::string, const toml::node*>> best;
    std::size_t best_distance = std::min<std::size_t>(4, std::max<std::size_t>(2, key.size() / 5 + 1));
    for (const auto& [k, value] : table_) {
      const std::string name(k.str());
      if (used_.count(name)) continue;
      const std::size_t d = edit_distance(name, key);
      if (d > 0 && d < best_distance) best.emplace(name, &value), best_distance = d;
    }
    return best;
  }

  bool has(const std::string& key) {
    use(key);
    return table_.contains(key);
  }

  std::optional<Real> optional_real(const std::string& key) {
    use(key);
    const toml::node* node = table_.get(key);
    if (!node) return std::nullopt;
    if (auto v = node->value_exact<double>()) return *v;
    if (auto v = node->value_exact<int64_t>()) return static_cast<Real>(*v);
    fail(key, "expected a number");
  }

  Real real(const std::string& key, Real fallback) { return optional_real(key).value_or(fallback); }

  Real positive(const std::string& key, Real fallback) {
    const Real v = real(key, fallback);
    if (!(v > 0) || !std::isfinite(v)) fail(key, "must be a finite number > 0" + unit(key) + ", got " + number(v));
    return v;
  }

  Real non_negative(const std::string& key, Real fallback) {
    const Real v = real(key, fallback);
    if (!(v >= 0) || !std::isfinite(v)) fail(key, "must be a finite number >= 0" + unit(key) + ", got " + number(v));
    return v;
  }

  Real required_positive(const std::string& key) {
    if (!table_.contains(key)) fail(key, "is required: a finite number > 0" + unit(key));
    return positive(key, 0);
  }

  int integer(const std::string& key, int fallback) {
    use(key);
    const toml::node* node = table_.get(key);
    if (!node) return fallback;
    if (auto v = node->value_exact<int64_t>()) {
      if (*v < std::numeric_limits<int>::min() || *v > std::numeric_limits<int>::max())
        fail(key, "integer out of range (at most " + std::to_string(std::numeric_limits<int>::max()) + ")");
      return static_cast<int>(*v);
    }
    fail(key, "expected an integer");
  }

  /// A non-negative 64-bit integer (seeds).
  std::uint64_t unsigned_integer(const std::string& key, std::uint64_t fallback) {
    use(key);
    const toml::node* node = table_.get(key);
    if (!node) return fallback;
    if (auto v = node->value_exact<int64_t>(); v && *v >= 0) return static_cast<std::uint64_t>(*v);
    fail(key, "expected a non-negative integer");
  }

  bool boolean(const std::string& key, bool fallback) {
    use(key);
    const toml::node* node = table_.get(key);
    if (!node) return fallback;
    if (auto v = node->value_exact<bool>()) return *v;
    fail(key, "expected true or false");
  }

  std::string string(const std::string& key, const std::string& fallback) {
    use(key);
    const toml::node* node = table_.get(key);
    if (!node) return fallback;
    if (auto v = node->value_exact<std::string>()) return *v;
    fail(key, "expected a string");
  }

  /// A string that must be one of `choices`; returns its index.
  std::size_t choice(const std::string& key, const std::vector<std::string>& choices, std::size_t fallback) {
    if (!table_.contains(key)) {
      use(key);
      return fallback;
    }
    const std::string v = string(key, "");
    for (std::size_t i = 0; i < choices.size(); ++i)
      if (choices[i] == v) return i;
    fail(key, "'" + v + "' is not valid; expected one of: " + join(choices));
  }

  Vec3 vec3(const std::string& key, const Vec3& fallback) {
    use(key);
    const toml::node* node = table_.get(key);
    if (!node) return fallback;
    const toml::array* a = node->as_array();
    if (!a || a->size() != 3) fail(key, "expected an array of 3 numbers [x, y, z]" + unit(key));
    Vec3 v;
    for (std::size_t i = 0; i < 3; ++i) {
      const toml::node& e = *a->get(i);
      if (auto d = e.value_exact<double>()) v[static_cast<int>(i)] = *d;
      else if (auto n = e.value_exact<int64_t>()) v[static_cast<int>(i)] = static_cast<Real>(*n);
      else fail_at(e.source().begin.line == 0 ? &e : node, key, "expected an array of 3 numbers [x, y, z]" + unit(key));
    }
    if (!v.allFinite()) fail(key, "components must be finite");
    return v;
  }

  /// An array of points [[x, y, z], ...].
  std::vector<Vec3> vec3_list(const std::string& key) {
    use(key);
    std::vector<Vec3> out;
    const toml::node* node = table_.get(key);
    if (!node) return out;
    const toml::array* a = node->as_array();
    if (!a) fail(key, "expected an array of points [[x, y, z], ...]");
    for (const toml::node& e : *a) {
      const toml::array* p = e.as_array();
      if (!p || p->size() != 3) fail_at(&e, key, "expected an array of points [[x, y, z], ...]");
      Vec3 v;
      for (std::size_t i = 0; i < 3; ++i) {
        const toml::node& c = *p->get(i);
        if (auto d = c.value_exact<double>()) v[static_cast<int>(i)] = *d;
        else if (auto n = c.value_exact<int64_t>()) v[static_cast<int>(i)] = static_cast<Real>(*n);
        else fail_at(&e, key, "expected an array of points [[x, y, z], ...]");
      }
      if (!v.allFinite()) fail_at(&e, key, "components must be finite");
      out.push_back(v);
    }
    return out;
  }

  const toml::table* table(const std::string& key) {
    use(key);
    const toml::node* node = table_.get(key);
    if (!node) return nullptr;
    if (const toml::table* t = node->as_table()) return t;
    fail(key, "expected a table");
  }

  /// An array of tables ([[key]] in TOML).
  std::vector<const toml::table*> tables(const std::string& key) {
    use(key);
    std::vector<const toml::table*> out;
    const toml::node* node = table_.get(key);
    if (!node) return out;
    const toml::array* a = node->as_array();
    if (!a) fail(key, "expected an array of tables ([[" + key + "]])");
    for (const toml::node& e : *a) {
      if (!e.as_table()) fail(key, "every entry must be a table");
      out.push_back(e.as_table());
    }
    return out;
  }

  const toml::node* node(const std::string& key) {
    use(key);
    return table_.get(key);
  }

  /// Throws for the first key that no getter asked for, suggesting the closest known one.
  void finish() const {
    for (const auto& [key, value] : table_) {
      const std::string k(key.str());
      if (used_.count(k)) continue;
      std::string best;
      std::size_t best_distance = 4;
      for (const auto& u : used_) {
        const std::size_t d = edit_distance(k, u);
        if (d < best_distance) best = u, best_distance = d;
      }
      std::string message = "unknown key";
      if (!best.empty()) message += "; did you mean '" + best + "'?";
      std::vector<std::string> known(used_.begin(), used_.end());
      message += " Valid keys here: " + join(known);
      const toml::source_region& where = value.source();
      if (where.begin.line == 0) message += " (set on the command line)";
      throw InputError(file_, static_cast<int>(where.begin.line), static_cast<int>(where.begin.column), field(k),
                       message);
    }
  }

  const std::string& file() const { return file_; }
  const toml::table& raw() const { return table_; }
  bool contains(const std::string& key) const { return table_.contains(key); }
  int line() const { return static_cast<int>(table_.source().begin.line); }
  int column() const { return static_cast<int>(table_.source().begin.column); }
  const std::string& path() const { return path_; }

  static std::string number(Real v) {
    std::ostringstream s;
    s << v;
    return s.str();
  }

 private:
  /// Marks `key` as known here (finish() accepts it). A key outside the schema is a bug of the
  /// loader, not of the scene: std::logic_error (tests and the fuzzer report it).
  const SceneKey& use(const std::string& key) {
    const std::string full = schema_path_.empty() ? key : schema_path_ + "." + key;
    const SceneKey* known = find_key(full);
    if (!known)
      throw std::logic_error("scene loader reads '" + full + "', which is not in its schema (scene_loader.cpp)");
    if (key_recorder) key_recorder->insert(full);
    used_.insert(key);
    return *known;
  }

  /// " (unit)" for a key with a physical unit, else nothing: for messages about its value.
  std::string unit(const std::string& key) { return with_unit(use(key).unit); }

  const toml::table& table_;
  std::string path_;
  const std::string& file_;
  std::string schema_path_;
  std::set<std::string> used_;
};

std::string indexed(const std::string& name, std::size_t i) { return name + "[" + std::to_string(i) + "]"; }

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

/// Every pair of materials that can meet needs contact parameters, from an entry naming the pair or
/// the default entry: two particle materials (a material with itself included), or a particle
/// material and a wall material. Walls never touch walls, so a pair of wall materials (or of
/// materials nothing uses) needs no entry. Called once particles and walls are read.
void check_contact_pairs(TableReader& top, const Scene& scene) {
  const auto& contacts = scene.world.contacts;
  const auto is_default = [](const ContactConfig& c) { return c.material_a.empty(); };
  if (std::any_of(contacts.begin(), contacts.end(), is_default)) return;
  const auto& materials = scene.world.materials;
  std::map<std::string, std::size_t> index;
  for (std::size_t i = 0; i < materials.size(); ++i) index[materials[i].name] = i;
  std::vector<bool> particle(materials.size()), wall(materials.size());  // used by particles, by walls
  for (const ParticleConfig& p : scene.world.particles) particle[index.at(p.material)] = true;
  for (const WallConfig& w : scene.world.walls) wall[index.at(w.material)] = true;
  for (std::size_t i = 0; i < materials.size(); ++i)
    for (std::size_t j = i; j < materials.size(); ++j) {
      const std::string &a = materials[i].name, &b = materials[j].name;
      std::string meet;
      if (particle[i] && particle[j])
        meet = i == j ? "particles of '" + a + "' touch each other"
                      : "particles of '" + a + "' touch particles of '" + b + "'";
      else if (particle[i] && wall[j])
        meet = "particles of '" + a + "' touch walls of '" + b + "'";
      else if (particle[j] && wall[i])
        meet = "particles of '" + b + "' touch walls of '" + a + "'";
      if (meet.empty()) continue;
      const bool covered = std::any_of(contacts.begin(), contacts.end(), [&](const ContactConfig& c) {
        return (c.material_a == a && c.material_b == b) || (c.material_a == b && c.material_b == a);
      });
      if (!covered)
        top.fail("contacts", "no contact parameters for materials '" + a + "' and '" + b + "' (" + meet +
                                 "): add a [[contacts]] entry with materials = [\"" + a + "\", \"" + b +
                                 "\"] and at least normal_stiffness, or one without `materials` as the default");
    }
}

void read_walls(TableReader& top, Scene& scene, const std::string& base_dir) {
  const auto tables = top.tables("walls");
  if (tables.size() > max_walls)
    top.fail("walls", "at most " + std::to_string(max_walls) + " walls, not " + std::to_string(tables.size()));
  for (std::size_t i = 0; i < tables.size(); ++i) {
    TableReader r(*tables[i], indexed("walls", i), top.file());
    WallConfig w;
    w.name = r.string("name", "wall" + std::to_string(i));
    const std::size_t kind = r.choice("type", {"plane", "box", "cylinder", "prism", "mesh"}, 99);
    if (kind == 99) r.fail("type", "is required: one of plane, box, cylinder, prism, mesh");
    w.kind = static_cast<WallKind>(kind);
    w.material = read_material_name(r, scene, "material");
    w.point = r.vec3("point", Vec3::Zero());
    if (w.kind == WallKind::plane) {
      w.normal = r.vec3("normal", Vec3::UnitZ());
      if (w.normal.norm() == 0) r.fail("normal", "must be a non-zero vector");
    } else if (w.kind == WallKind::box) {
      w.half_extents = r.vec3("half_extents", Vec3::Ones());
      if (!(w.half_extents.minCoeff() > 0)) r.fail("half_extents", "all three half edge lengths must be > 0");
      w.inside = r.boolean("inside", true);
    } else if (w.kind == WallKind::cylinder) {
      w.axis = r.vec3("axis", Vec3::UnitZ());
      if (w.axis.norm() == 0) r.fail("axis", "must be a non-zero vector");
      w.radius = r.required_positive("radius");
      if (r.has("length")) w.length = r.positive("length", 1);
    } else if (w.kind == WallKind::mesh) {
      w.scale = r.positive("scale", 1);
      const std::string name = r.string("file", "");
      if (name.empty()) r.fail("file", "is required: an STL file (binary or ASCII), relative to the scene file");
      const std::filesystem::path path = std::filesystem::path(base_dir) / name;
      if (!std::filesystem::exists(path)) r.fail("file", "file not found: " + path.string());
      w.file = path.string();
      try {
        w.mesh = std::make_shared<const TriangleMesh>(read_stl_mesh(w.file, w.scale));
      } catch (const InputError& e) {
        r.fail("file", std::string("not a valid STL file: ") + e.what());
      } catch (const std::invalid_argument& e) {
        r.fail("file", std::string("not a valid STL file: ") + w.file + ": " + e.what());
      }
      if (w.mesh->feature_count() >= max_wall_features)
        r.fail("file", "the mesh has " + std::to_string(w.mesh->feature_count()) + " faces, edges and vertices; at most " +
                           std::to_string(max_wall_features - 1) + " fit a contact key");
    } else {
      w.axis = r.vec3("axis", Vec3::UnitZ());
      if (w.axis.norm() == 0) r.fail("axis", "must be a non-zero vector");
      if (r.has("length")) w.length = r.positive("length", 1);
      if (!r.has("profile")) r.fail("profile", "is required: the corners of the cross-section [[x, y, z], ...]");
      w.profile = r.vec3_list("profile");
      try {
        Walls::check_prism(w);
      } catch (const std::invalid_argument& e) {
        r.fail("profile", e.what());
      }
    }
    w.velocity = r.vec3("velocity", Vec3::Zero());
    w.angular_velocity = r.vec3("angular_velocity", Vec3::Zero());
    if (r.has("rotation_center")) {
      w.rotation_center = r.vec3("rotation_center", Vec3::Zero());
      w.use_rotation_center = true;
    }
    w.ramp_time = r.non_negative("ramp_time", 0);
    r.finish();
    scene.world.walls.push_back(w);
  }
}

/// The `size` table of a generator or a mill charge: the radius distribution.
void read_size(TableReader& r, GeneratorConfig& g) {
  const toml::table* size = r.table("size");
  if (!size) r.fail("size", "is required: { distribution = \"mono\", radius = ... } (or uniform, normal, lognormal)");
  {
    TableReader s(*size, r.field("size"), r.file());
    g.distribution = static_cast<SizeDistribution>(s.choice("distribution", {"mono", "uniform", "normal", "lognormal"}, 0));
    switch (g.distribution) {
      case SizeDistribution::mono:
        g.r_min = g.r_max = g.mean = s.required_positive("radius");
        break;
      case SizeDistribution::uniform:
        g.r_min = s.required_positive("min");
        g.r_max = s.required_positive("max");
        break;
      case SizeDistribution::normal:
      case SizeDistribution::lognormal:
        g.mean = s.required_positive(g.distribution == SizeDistribution::normal ? "mean" : "median");
        g.sigma = s.non_negative(g.distribution == SizeDistribution::normal ? "std" : "sigma", 0);
        g.r_min = s.required_positive("min");
        g.r_max = s.required_positive("max");
        break;
    }
    if (g.r_max < g.r_min) s.fail("max", "must be >= min");
    s.finish();
  }
}

ParticleSource source_of(const toml::node& node, const std::string& file, const std::string& field) {
  return {file, static_cast<int>(node.source().begin.line), static_cast<int>(node.source().begin.column), field};
}

/// Reads [[particles]], [[particle_files]] and [[generators]]; `id_cells` gets, per particle, where
/// its id was given (a CSV cell; empty for a particle without one).
void read_particles(TableReader& top, Scene& scene, const std::string& base_dir,
                    std::vector<ParticleSource>& id_cells) {
  const auto explicit_list = top.tables("particles");
  for (std::size_t i = 0; i < explicit_list.size(); ++i) {
    TableReader r(*explicit_list[i], indexed("particles", i), top.file());
    ParticleConfig p;
    p.position = r.vec3("position", Vec3::Zero());
    p.velocity = r.vec3("velocity", Vec3::Zero());
    p.angular_velocity = r.vec3("angular_velocity", Vec3::Zero());
    p.radius = r.required_positive("radius");
    if (r.has("mass")) p.mass = r.positive("mass", 1);
    if (r.has("density")) p.density = r.positive("density", 1);
    p.material = read_material_name(r, scene, "material");
    r.finish();
    scene.world.particles.push_back(p);
    scene.sources.push_back(source_of(*explicit_list[i], top.file(), r.path()));
  }
  const auto files = top.tables("particle_files");
  for (std::size_t i = 0; i < files.size(); ++i) {
    TableReader r(*files[i], indexed("particle_files", i), top.file());
    const std::string name = r.string("file", "");
    if (name.empty()) r.fail("file", "is required: a CSV file with columns x, y, z, radius (see scenes/README.md)");
    const std::string material = read_material_name(r, scene, "material");
    const Vec3 offset = r.vec3("offset", Vec3::Zero());
    r.finish();
    const std::filesystem::path path = std::filesystem::path(base_dir) / name;
    if (!std::filesystem::exists(path)) r.fail("file", "file not found: " + path.string());
    ParticleCsvLayout layout;
    std::vector<ParticleConfig> loaded = read_particle_csv(path.string(), material, &layout);
    for (std::size_t k = 0; k < loaded.size(); ++k) {
      const int line = layout.lines[k];
      if (layout.material_column > 0 && !known_material(scene, loaded[k].material))
        throw InputError(path.string(), line, layout.material_column, "material",
                         "unknown material '" + loaded[k].material + "'; defined: " + material_names(scene));
      loaded[k].position += offset;
      id_cells.resize(scene.world.particles.size());
      id_cells.push_back({path.string(), line, layout.id_column, "id"});
      scene.world.particles.push_back(loaded[k]);
      scene.sources.push_back({path.string(), line, 1, r.path() + " row " + std::to_string(k + 1)});
    }
  }
  const auto generators = top.tables("generators");
  for (std::size_t i = 0; i < generators.size(); ++i) {
    TableReader r(*generators[i], indexed("generators", i), top.file());
    GeneratorConfig g;
    g.count = r.integer("count", 0);
    if (g.count <= 0) r.fail("count", "must be a positive number of particles");
    g.seed = r.unsigned_integer("seed", 1);
    g.material = read_material_name(r, scene, "material");
    g.velocity = r.vec3("velocity", Vec3::Zero());
    g.max_attempts = r.integer("max_attempts", 1000);
    g.dimension = scene.world.model.dimension;
    const toml::table* region = r.table("region");
    if (!region) r.fail("region", "is required: { type = \"box\", min = [...], max = [...] } or { type = \"cylinder\", ... }");
    {
      TableReader reg(*region, r.field("region"), top.file());
      g.region = reg.choice("type", {"box", "cylinder"}, 0) == 0 ? GeneratorRegion::box : GeneratorRegion::cylinder;
      if (g.region == GeneratorRegion::box) {
        g.min = reg.vec3("min", Vec3::Zero());
        g.max = reg.vec3("max", Vec3::Ones());
        if (!((g.max - g.min).minCoeff() >= 0)) reg.fail("max", "must be >= min in every component");
      } else {
        g.center = reg.vec3("center", Vec3::Zero());
        g.axis = reg.vec3("axis", Vec3::UnitZ());
        if (g.axis.norm() == 0) reg.fail("axis", "must be a non-zero vector");
        g.radius = reg.required_positive("radius");
        g.length = reg.non_negative("length", 0);
      }
      reg.finish();
    }
    read_size(r, g);
    r.finish();
    const std::size_t before = scene.world.particles.size();
    const GeneratorResult result = generate_particles(g, scene.world.particles);
    if (!result.ok) r.fail("count", result.message);
    for (std::size_t k = before; k < scene.world.particles.size(); ++k)
      scene.sources.push_back(source_of(*generators[i], top.file(), r.path()));
    scene.seeds.push_back(g.seed);
  }
}

/// Returns whether the scene sets level_max.
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

/// Splits "a.b[2].c" into steps; a step is a key or an array index.
struct PathStep {
  std::string key;
  int index = -1;
};

std::vector<PathStep> parse_path(const std::string& path, const std::string& option) {
  std::vector<PathStep> steps;
  std::string token;
  std::istringstream in(path);
  while (std::getline(in, token, '.')) {
    PathStep step;
    const auto bracket = token.find('[');
    step.key = token.substr(0, bracket);
    if (step.key.empty()) throw InputError("--set", 0, 0, path, "empty key in '" + option + "'");
    steps.push_back(step);
    std::size_t pos = bracket;
    while (pos != std::string::npos) {
      const auto close = token.find(']', pos);
      if (close == std::string::npos) throw InputError("--set", 0, 0, path, "missing ']' in '" + option + "'");
      PathStep index;
      try {
        index.index = std::stoi(token.substr(pos + 1, close - pos - 1));
      } catch (...) {
        throw InputError("--set", 0, 0, path, "array index must be an integer in '" + option + "'");
      }
      steps.push_back(index);
      pos = token.find('[', close);
    }
  }
  return steps;
}

/// Applies "a.b[i].c=value": the value is parsed as TOML (a bare word becomes a string).
void apply_override(toml::table& root, const std::string& option) {
  const auto eq = option.find('=');
  if (eq == std::string::npos || eq == 0) throw InputError("--set", 0, 0, "", "expected key.path=value, got '" + option + "'");
  const std::string path = option.substr(0, eq), text = option.substr(eq + 1);
  toml::table parsed;
  try {
    parsed = toml::parse("v = " + text);
  } catch (const toml::parse_error&) {
    parsed = toml::table{{"v", text}};
  }
  const std::vector<PathStep> steps = parse_path(path, option);
  toml::node* current = &root;
  for (std::size_t s = 0; s + 1 < steps.size(); ++s) {
    const PathStep& step = steps[s];
    if (step.index >= 0) {
      toml::array* a = current->as_array();
      if (!a || step.index >= static_cast<int>(a->size()))
        throw InputError("--set", 0, 0, path, "no array element [" + std::to_string(step.index) + "] on this path");
      current = a->get(static_cast<std::size_t>(step.index));
    } else {
      toml::table* t = current->as_table();
      if (!t) throw InputError("--set", 0, 0, path, "'" + step.key + "' is not inside a table");
      if (!t->contains(step.key)) t->insert(step.key, toml::table{});
      current = t->get(step.key);
    }
  }
  const PathStep& last = steps.back();
  toml::node& value = *parsed.get("v");
  if (last.index >= 0) {
    toml::array* a = current->as_array();
    if (!a || last.index >= static_cast<int>(a->size()))
      throw InputError("--set", 0, 0, path, "no array element [" + std::to_string(last.index) + "] on this path");
    a->replace(a->begin() + last.index, value);
  } else {
    toml::table* t = current->as_table();
    if (!t) throw InputError("--set", 0, 0, path, "'" + last.key + "' is not inside a table");
    t->insert_or_assign(last.key, value);
  }
}

std::uint64_t fnv1a(const std::string& text) {
  std::uint64_t h = 14695981039346656037ull;
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  return h;
}

/// FNV-1a of a mesh's vertex coordinates and corner indices.
std::uint64_t mesh_fingerprint(const TriangleMesh& mesh) {
  std::string bytes;
  bytes.append(reinterpret_cast<const char*>(mesh.vertices().data()), mesh.vertices().size() * sizeof(Vec3));
  bytes.append(reinterpret_cast<const char*>(mesh.triangles().data()),
               mesh.triangles().size() * sizeof(std::array<std::uint32_t, 3>));
  return fnv1a(bytes);
}

/// When a particle file gives ids: gives every particle its id, the one its file gave, else (in
/// scene order) the next after the largest id given; orders particles (and their sources) by id, as
/// a World needs them (slots follow ids); rejects an id given twice. A scene without ids keeps its
/// order and leaves ids to the World, which numbers particles 0, 1, 2, ... in that order.
void assign_particle_ids(Scene& scene, std::vector<ParticleSource> id_cells) {
  std::vector<ParticleConfig>& particles = scene.world.particles;
  const std::size_t n = particles.size();
  id_cells.resize(n);
  std::optional<std::size_t> largest;  // the particle with the largest given id
  for (std::size_t i = 0; i < n; ++i)
    if (particles[i].id && (!largest || *particles[i].id > *particles[*largest].id)) largest = i;
  if (!largest) return;
  const auto fail_at = [&](std::size_t i, const std::string& message) {
    const ParticleSource& c = id_cells[i];
    throw InputError(c.file, c.line, c.column, c.field, message);
  };
  // A World maps every id up to the largest to a slot (4 bytes each): ids far beyond the particle
  // count would make that map huge.
  constexpr std::uint64_t spare_ids = std::uint64_t{1} << 26;
  const std::uint64_t top = *particles[*largest].id;
  if (top >= n + spare_ids)
    fail_at(*largest, "id " + std::to_string(top) + " leaves more than " + std::to_string(spare_ids) +
                          " ids unused below it (the engine keeps a slot for every id up to the largest): number the "
                          "particles from 0, below " + std::to_string(n + spare_ids));
  std::uint64_t next = top + 1;  // below n + spare_ids + n: far inside ParticleId
  for (std::size_t i = 0; i < n; ++i)
    if (!particles[i].id) particles[i].id = static_cast<ParticleId>(next++);
  std::vector<std::size_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return *particles[a].id < *particles[b].id; });
  for (std::size_t k = 1; k < n; ++k) {
    const std::size_t a = order[k - 1], b = order[k];
    if (*particles[a].id == *particles[b].id) {
      const ParticleSource& other = id_cells[a];
      fail_at(b, "id " + std::to_string(*particles[b].id) + " is also given in " + other.file + " line " +
                     std::to_string(other.line) + ": every particle needs its own id, a whole number from 0 to " +
                     std::to_string(std::numeric_limits<ParticleId>::max() - 1));
    }
  }
  std::vector<ParticleConfig> sorted_particles(n);
  std::vector<ParticleSource> sorted_sources(n);
  for (std::size_t k = 0; k < n; ++k) {
    sorted_particles[k] = std::move(particles[order[k]]);
    sorted_sources[k] = std::move(scene.sources[order[k]]);
  }
  particles = std::move(sorted_particles);
  scene.sources = std::move(sorted_sources);
}

}  // namespace

const std::vector<SceneKey>& scene_keys() { return schema; }

SceneKeyRecorder::SceneKeyRecorder() : previous_(key_recorder) { key_recorder = &keys_; }
SceneKeyRecorder::~SceneKeyRecorder() { key_recorder = previous_; }

Scene load_scene_text(const std::string& text, const std::string& file, const std::string& base_dir,
                      const std::vector<std::string>& overrides) {
  toml::table root;
  try {
    root = toml::parse(text, file);
  } catch (const toml::parse_error& e) {
    throw InputError(file, static_cast<int>(e.source().begin.line), static_cast<int>(e.source().begin.column), "",
                     "TOML syntax error: " + std::string(e.description()));
  }
  for (const std::string& o : overrides) apply_override(root, o);

  Scene scene;
  scene.file = file;
  scene.name = std::filesystem::path(file).stem().string();
  TableReader top(root, "", file);
  if (const toml::table* t = top.table("scene")) {
    TableReader r(*t, "scene", file);
    read_model(r, scene);
    r.finish();
  }
  read_materials(top, scene);
  read_contacts(top, scene);
  read_walls(top, scene, base_dir);
  std::vector<ParticleSource> id_cells;
  read_particles(top, scene, base_dir, id_cells);
  read_mill(top, scene);
  check_contact_pairs(top, scene);
  const bool level_max_given = read_integrator(top, scene);
  read_run_and_output(top, scene);
  read_accuracy(top, scene);
  top.finish();
  // Outputs happen at sync times, so by default a doubling run's longest step (the sync interval)
  // is at most the output interval: `--set integrator.control=doubling` keeps a scene's rows.
  IntegratorConfig& integrator = scene.world.integrator;
  std::string derived;
  if (integrator.control == Control::doubling && !level_max_given) {
    const Real dt_base = integrator.dt_base > 0 ? integrator.dt_base : integrator.dt;
    const Real steps = std::floor(std::log2(scene.output.interval / dt_base) + 1e-9);
    integrator.level_max = static_cast<int>(std::clamp(steps, Real(integrator.level_min), Real(10)));
    derived = "\nderived level_max = " + std::to_string(integrator.level_max);
  }
  if (scene.world.particles.empty())
    top.fail("particles", "the scene has no particles: add [[particles]], [[particle_files]] or [[generators]]");
  assign_particle_ids(scene, std::move(id_cells));
  // The physics hash ignores how long the run lasts and what it writes, so a run can be resumed
  // with another end time or output interval, but never with other physics.
  toml::table physics = root;
  physics.erase("run");
  physics.erase("output");
  physics.erase("accuracy");
  // A mesh wall's triangles are physics too, whatever file they came from.
  for (const WallConfig& w : scene.world.walls)
    if (w.mesh) derived += "\nmesh " + w.name + " " + std::to_string(mesh_fingerprint(*w.mesh));
  std::ostringstream resolved;
  resolved << physics << derived;  // a level_max derived from the output interval is physics too
  scene.physics_hash = fnv1a(resolved.str());
  check_initial_state(scene);
  return scene;
}

Scene load_scene(const std::string& path, const std::vector<std::string>& overrides) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, 0, "", "cannot open the scene file");
  std::stringstream text;
  text << in.rdbuf();
  return load_scene_text(text.str(), path, std::filesystem::path(path).parent_path().string(), overrides);
}

void check_initial_state(const Scene& scene) {
  const auto& particles = scene.world.particles;
  auto fail = [&](std::size_t p, const std::string& message) {
    const ParticleSource& s = p < scene.sources.size() ? scene.sources[p] : ParticleSource{scene.file, 0, 0, ""};
    throw InputError(s.file, s.line, s.column, s.field, message);
  };
  // Messages name particles by id (as outputs do); a scene made in code may leave ids to the World.
  const auto id_of = [&](std::size_t p) -> std::uint64_t {
    return particles[p].id.value_or(static_cast<ParticleId>(p));
  };
  std::vector<Vec3> position(particles.size());
  std::vector<Real> radius(particles.size());
  for (std::size_t p = 0; p < particles.size(); ++p) {
    position[p] = particles[p].position;
    radius[p] = particles[p].radius;
    if (scene.world.model.dimension == 2) position[p].z() = 0;
  }
  broadphase::GridBroadphase grid;
  broadphase::CandidatePairs pairs;
  grid.find_pairs(position, radius, 0, pairs);
  for (std::size_t a = 0; a < particles.size(); ++a)
    for (std::uint32_t k = pairs.row_start[a]; k < pairs.row_start[a + 1]; ++k) {
      const std::size_t b = pairs.partner[k];
      const Real overlap = radius[a] + radius[b] - (position[a] - position[b]).norm();
      const Real allowed = scene.max_initial_overlap * std::min(radius[a], radius[b]);
      if (overlap > allowed) {
        std::ostringstream m;
        m << "particle " << id_of(b) << " overlaps particle " << id_of(a) << " by " << overlap
          << " m at the start; at most " << allowed << " m (scene.max_initial_overlap = " << scene.max_initial_overlap
          << " of the smaller radius) is allowed";
        fail(b, m.str());
      }
    }
  MaterialTable materials(scene.world.materials, scene.world.contacts, scene.world.model.separation);
  Walls walls(scene.world.walls, materials);
  for (std::size_t p = 0; p < particles.size(); ++p)
    for (std::size_t w = 0; w < walls.count(); ++w) {
      const WallConfig& c = walls.config(w);
      WallTouch touch;
      bool outside = false;
      Real overlap = 0;
      std::vector<std::uint32_t> features(walls.touching_count(w, position[p], radius[p]));
      walls.touching_features(w, position[p], radius[p], features.data());
      for (const std::uint32_t f : features) {
        if (walls.touch(w, f, position[p], radius[p], touch)) overlap = std::max(overlap, touch.overlap);
      }
      if (c.kind == WallKind::plane) outside = (position[p] - walls.point(w)).dot(c.normal.normalized()) < 0;
      if (c.kind == WallKind::box && c.inside) {
        const Vec3 local = position[p] - walls.point(w);
        outside = (local.cwiseAbs() - c.half_extents).maxCoeff() > 0;
      }
      if (c.kind == WallKind::cylinder) {
        const Vec3 rel = position[p] - walls.point(w);
        const Vec3 axis = c.axis.normalized();
        outside = (rel - rel.dot(axis) * axis).norm() > c.radius && std::abs(rel.dot(axis)) <= 0.5 * c.length;
      }
      if (outside) fail(p, "particle " + std::to_string(id_of(p)) + " starts outside wall '" + c.name + "'");
      if (overlap > scene.max_initial_overlap * radius[p]) {
        std::ostringstream m;
        m << "particle " << id_of(p) << " overlaps wall '" << c.name << "' by " << overlap
          << " m at the start; at most " << scene.max_initial_overlap * radius[p]
          << " m (scene.max_initial_overlap of its radius) is allowed";
        fail(p, m.str());
      }
    }
}

}  // namespace dem
