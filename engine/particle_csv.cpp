#include "engine/particle_csv.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>

#include "engine/input_error.h"
#include "engine/output.h"

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

}  // namespace

std::vector<ParticleConfig> read_particle_csv(const std::string& path, const std::string& material) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, 0, "", "cannot open the particle file");
  std::string line;
  if (!std::getline(in, line)) throw InputError(path, 1, 1, "", "empty file: expected a header row such as x,y,z,radius");
  const std::vector<std::string> header = split(line);
  std::map<std::string, int> column;
  const std::vector<std::string> known = {"id", "x", "y", "z", "vx", "vy", "vz", "wx", "wy", "wz", "radius", "density", "mass"};
  for (std::size_t c = 0; c < header.size(); ++c) {
    bool ok = false;
    for (const auto& k : known) ok = ok || header[c] == k;
    if (!ok)
      throw InputError(path, 1, static_cast<int>(c + 1), header[c],
                       "unknown column; valid: id, x, y, z, vx, vy, vz, wx, wy, wz, radius, density, mass");
    column[header[c]] = static_cast<int>(c);
  }
  for (const char* required : {"x", "y", "z", "radius"})
    if (!column.count(required)) throw InputError(path, 1, 1, required, "required column is missing");

  std::vector<ParticleConfig> particles;
  int line_number = 1;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::vector<std::string> cells = split(line);
    if (cells.size() != header.size())
      throw InputError(path, line_number, 1, "",
                       "row has " + std::to_string(cells.size()) + " cells, the header has " + std::to_string(header.size()));
    auto value = [&](const char* name, Real fallback) {
      const auto it = column.find(name);
      if (it == column.end()) return fallback;
      const std::string& text = cells[it->second];
      Real v = 0;
      const auto [end, err] = std::from_chars(text.data(), text.data() + text.size(), v);
      if (err != std::errc() || end != text.data() + text.size() || text.empty())
        throw InputError(path, line_number, it->second + 1, name, "'" + text + "' is not a number");
      if (!std::isfinite(v))
        throw InputError(path, line_number, it->second + 1, name, "'" + text + "' is not a finite number");
      return v;
    };
    ParticleConfig p;
    p.material = material;
    p.position = Vec3(value("x", 0), value("y", 0), value("z", 0));
    p.velocity = Vec3(value("vx", 0), value("vy", 0), value("vz", 0));
    p.angular_velocity = Vec3(value("wx", 0), value("wy", 0), value("wz", 0));
    p.radius = value("radius", 0);
    p.density = value("density", 0);
    p.mass = value("mass", 0);
    if (!(p.radius > 0))
      throw InputError(path, line_number, column["radius"] + 1, "radius", "must be a positive length in metres");
    for (const char* name : {"density", "mass"})
      if (column.count(name) && !(value(name, 0) > 0))
        throw InputError(path, line_number, column[name] + 1, name, "must be > 0 when given");
    particles.push_back(p);
  }
  return particles;
}

void write_particle_csv(const std::string& path, const std::vector<ParticleConfig>& particles) {
  std::ostringstream out;
  out.precision(17);
  out << "id,x,y,z,vx,vy,vz,wx,wy,wz,radius,density\n";
  for (std::size_t i = 0; i < particles.size(); ++i) {
    const ParticleConfig& p = particles[i];
    out << i + 1 << ',' << p.position.x() << ',' << p.position.y() << ',' << p.position.z() << ',' << p.velocity.x()
        << ',' << p.velocity.y() << ',' << p.velocity.z() << ',' << p.angular_velocity.x() << ','
        << p.angular_velocity.y() << ',' << p.angular_velocity.z() << ',' << p.radius << ',' << p.density << '\n';
  }
  write_file_atomically(path, out.str());
}

}  // namespace dem
