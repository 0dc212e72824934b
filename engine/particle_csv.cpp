#include "engine/particle_csv.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "engine/input_error.h"
#include "engine/atomic_file.h"

namespace dem {
namespace {

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> cells;
  std::string cell;
  std::istringstream in(line);
  while (std::getline(in, cell, ',')) {
    const auto b = cell.find_first_not_of(" \t\r");
    const auto e = cell.find_last_not_of(" \t\r");
    cells.push_back(b == std::string::npos ? std::string() : cell.substr(b, e - b + 1));
  }
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

// The largest id a file may give: ParticleId's range less its all-ones value.
constexpr std::uint64_t max_id = std::numeric_limits<ParticleId>::max() - 1;

const std::string valid_columns = "id, x, y, z, vx, vy, vz, wx, wy, wz, radius, density, mass, material";
const std::string valid_id = "a whole number from 0 to " + std::to_string(max_id);

}  // namespace

bool fits_csv_cell(const std::string& name) {
  if (name.empty() || name.find_first_of(",\"\r\n") != std::string::npos) return false;
  return name.find_first_not_of(" \t") == 0 && name.find_last_not_of(" \t") == name.size() - 1;
}

std::vector<ParticleConfig> read_particle_csv(const std::string& path, const std::string& material,
                                              ParticleCsvLayout* layout) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, 0, "", "cannot open the particle file");
  std::string line;
  if (!std::getline(in, line)) throw InputError(path, 1, 1, "", "empty file: expected a header row such as x,y,z,radius");
  const std::vector<std::string> header = split(line);
  std::map<std::string, int> column;  // name -> 0-based column
  const std::vector<std::string> known = {"id", "x",  "y",  "z",      "vx",      "vy",   "vz",
                                          "wx", "wy", "wz", "radius", "density", "mass", "material"};
  for (std::size_t c = 0; c < header.size(); ++c) {
    bool ok = false;
    for (const auto& k : known) ok = ok || header[c] == k;
    if (!ok) throw InputError(path, 1, static_cast<int>(c + 1), header[c], "unknown column; valid: " + valid_columns);
    if (column.count(header[c]))
      throw InputError(path, 1, static_cast<int>(c + 1), header[c],
                       "column given twice (also column " + std::to_string(column[header[c]] + 1) +
                           "); give each once");
    column[header[c]] = static_cast<int>(c);
  }
  for (const char* required : {"x", "y", "z", "radius"})
    if (!column.count(required))
      throw InputError(path, 1, 1, required, "required column is missing; the header needs at least x, y, z, radius");
  const auto column_of = [&](const char* name) { return column.count(name) ? column.at(name) + 1 : 0; };
  if (layout) *layout = ParticleCsvLayout{{}, column_of("id"), column_of("material")};

  std::vector<ParticleConfig> particles;
  std::unordered_map<ParticleId, int> line_of_id;  // for a repeated id: where it was first
  int line_number = 1;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::vector<std::string> cells = split(line);
    if (cells.size() != header.size())
      throw InputError(path, line_number, 1, "",
                       "row has " + std::to_string(cells.size()) + " cells, the header has " + std::to_string(header.size()));
    const auto fail = [&](const char* name, const std::string& message) -> void {
      throw InputError(path, line_number, column.at(name) + 1, name, message);
    };
    // A number from a cell; nothing when the column is absent, or the cell empty where allowed.
    const auto number = [&](const char* name, bool may_be_empty) -> std::optional<Real> {
      const auto it = column.find(name);
      if (it == column.end()) return std::nullopt;
      const std::string& text = cells[it->second];
      if (text.empty() && may_be_empty) return std::nullopt;
      Real v = 0;
      const auto [end, err] = std::from_chars(text.data(), text.data() + text.size(), v);
      if (err != std::errc() || end != text.data() + text.size() || text.empty())
        fail(name, "'" + text + "' is not a number");
      if (!std::isfinite(v)) fail(name, "'" + text + "' is not a finite number");
      return v;
    };
    const auto value = [&](const char* name) { return number(name, false).value_or(0); };
    ParticleConfig p;
    p.material = material;
    p.position = Vec3(value("x"), value("y"), value("z"));
    p.velocity = Vec3(value("vx"), value("vy"), value("vz"));
    p.angular_velocity = Vec3(value("wx"), value("wy"), value("wz"));
    p.radius = value("radius");
    if (!(p.radius > 0)) fail("radius", "must be a positive length (m)");
    const std::optional<Real> density = number("density", true), mass = number("mass", true);
    if (density && !(*density > 0))
      fail("density", "must be > 0 (kg/m³), or the cell left empty for the material's density");
    if (mass && !(*mass > 0)) fail("mass", "must be > 0 (kg), or the cell left empty");
    if (density && mass)
      fail("mass", "give the mass (kg) or the density (kg/m³) of a particle, not both: empty one cell");
    p.density = density.value_or(0);
    p.mass = mass.value_or(0);
    if (column.count("id")) {
      const std::string& text = cells[column.at("id")];
      std::uint64_t id = 0;
      const auto [end, err] = std::from_chars(text.data(), text.data() + text.size(), id);
      if (err != std::errc() || end != text.data() + text.size() || text.empty() || id > max_id)
        fail("id", "'" + text + "' is not a valid id: " + valid_id);
      const auto [first, fresh] = line_of_id.emplace(static_cast<ParticleId>(id), line_number);
      if (!fresh)
        fail("id", "id " + text + " is also on line " + std::to_string(first->second) +
                       ": every particle needs its own id, " + valid_id);
      p.id = static_cast<ParticleId>(id);
    }
    if (column.count("material")) {
      p.material = cells[column.at("material")];
      if (p.material.empty()) fail("material", "empty cell: give the name of a material of the scene");
    }
    particles.push_back(p);
    if (layout) layout->lines.push_back(line_number);
  }
  return particles;
}

void write_particle_csv(const std::string& path, const std::vector<ParticleConfig>& particles) {
  std::string out = std::string(particle_csv_header) + "\n";
  char cell[32];
  const auto put = [&](Real v) {
    std::snprintf(cell, sizeof cell, "%.17g", v);
    out += cell;
    out += ',';
  };
  std::uint64_t next = 0;  // as World::add_particles: an id not given is the next after the largest
  for (const ParticleConfig& p : particles) {
    if (p.id && *p.id < next)
      throw std::invalid_argument("write_particle_csv: particle id " + std::to_string(*p.id) +
                                  " is not above the id before it; ids must increase");
    if (!fits_csv_cell(p.material))
      throw std::invalid_argument("write_particle_csv: material name '" + p.material +
                                  "' does not fit a CSV cell (a comma, quote or line break, or a space at an end)");
    const std::uint64_t id = p.id.value_or(static_cast<ParticleId>(next));
    next = id + 1;
    out += std::to_string(id) + ',';
    for (const Vec3* v : {&p.position, &p.velocity, &p.angular_velocity})
      for (int k = 0; k < 3; ++k) put((*v)[k]);
    put(p.radius);
    if (p.mass > 0) {
      out += ',';
      put(p.mass);
    } else if (p.density > 0) {
      put(p.density);
      out += ',';
    } else {
      out += ",,";
    }
    out += p.material;
    out += '\n';
  }
  write_file_atomically(path, out);
}

}  // namespace dem
