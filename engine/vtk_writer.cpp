#include "engine/vtk_writer.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <stdexcept>
#include <string_view>
#include <type_traits>
#include <utility>

#include "engine/atomic_file.h"
#include "engine/number_text.h"

namespace dem {
namespace {

// ---- XML -------------------------------------------------------------------------------------------

std::string xml_escape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (const char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

// Inverse of xml_escape for the five named entities; false on any other '&' sequence.
bool xml_unescape(std::string_view s, std::string& out) {
  static constexpr std::pair<std::string_view, char> entities[] = {
      {"&amp;", '&'}, {"&lt;", '<'}, {"&gt;", '>'}, {"&quot;", '"'}, {"&apos;", '\''}};
  out.clear();
  std::size_t i = 0;
  while (i < s.size()) {
    if (s[i] != '&') {
      out += s[i++];
      continue;
    }
    bool known = false;
    for (const auto& [name, c] : entities) {
      if (s.substr(i, name.size()) == name) {
        out += c;
        i += name.size();
        known = true;
        break;
      }
    }
    if (!known) return false;
  }
  return true;
}

// The value of attribute `name` inside the tag text `tag`, escaped as written; false if absent.
bool find_attribute(std::string_view tag, std::string_view name, std::string_view& value) {
  std::size_t from = 0;
  for (;;) {
    const std::size_t at = tag.find(name, from);
    if (at == std::string_view::npos) return false;
    const std::size_t eq = at + name.size();
    const bool starts_word = at > 0 && (tag[at - 1] == ' ' || tag[at - 1] == '\t' || tag[at - 1] == '\n');
    if (starts_word && eq + 1 < tag.size() && tag[eq] == '=' && tag[eq + 1] == '"') {
      const std::size_t end = tag.find('"', eq + 2);
      if (end == std::string_view::npos) return false;
      value = tag.substr(eq + 2, end - eq - 2);
      return true;
    }
    from = at + 1;
  }
}

// ---- PolyData files ---------------------------------------------------------------------------------

// Appends `value`'s bytes little-endian, whatever the machine's byte order.
template <typename T>
void append_little_endian(std::string& out, T value) {
  auto bytes = std::bit_cast<std::array<char, sizeof(T)>>(value);
  if constexpr (std::endian::native == std::endian::big) std::reverse(bytes.begin(), bytes.end());
  out.append(bytes.data(), bytes.size());
}

template <typename T>
void append_text(std::string& out, T value) {
  if constexpr (std::is_floating_point_v<T>) {
    text::append_double(out, value);
  } else {
    text::append_integer(out, value);
  }
}

// A VTK XML PolyData file under construction: the caller adds the elements' text and the data arrays,
// which go inline as text (ASCII) or into one appended raw block (binary) that `finish` puts at the end.
class PolyDataFile {
 public:
  explicit PolyDataFile(VtkFormat format) : format_(format) {
    out_ =
        "<?xml version=\"1.0\"?>\n"
        "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n"
        "  <PolyData>\n";
  }

  void put(std::string_view s) { out_ += s; }
  void number(std::size_t n) { text::append_integer(out_, n); }

  /// One <DataArray> of `count` tuples of `components` values `get(i, c)` of type T (VTK name `type`).
  /// ASCII puts `per_line` values on a line (a tuple when 0).
  template <typename T, typename Get>
  void array(const char* type, const char* name, int components, std::size_t count, Get get, int per_line = 0) {
    open_array(type, name, components);
    const std::size_t values = count * static_cast<std::size_t>(components);
    if (format_ == VtkFormat::binary) {
      append_little_endian<std::uint64_t>(appended_, values * sizeof(T));
      for (std::size_t i = 0; i < count; ++i) {
        for (int c = 0; c < components; ++c) append_little_endian<T>(appended_, static_cast<T>(get(i, c)));
      }
      return;
    }
    const std::size_t line = per_line > 0 ? static_cast<std::size_t>(per_line) : static_cast<std::size_t>(components);
    std::size_t k = 0;
    for (std::size_t i = 0; i < count; ++i) {
      for (int c = 0; c < components; ++c, ++k) {
        out_ += k % line == 0 ? "          " : " ";
        append_text<T>(out_, static_cast<T>(get(i, c)));
        if ((k + 1) % line == 0) out_ += '\n';
      }
    }
    if (k % line != 0) out_ += '\n';
    out_ += "        </DataArray>\n";
  }

  /// A String <DataArray>: each string's bytes and a terminating 0 (in ASCII, as the bytes' numbers).
  void string_array(const char* name, const std::vector<std::string>& strings) {
    out_ += "        <DataArray type=\"String\" Name=\"";
    out_ += name;
    out_ += "\" NumberOfTuples=\"";
    text::append_integer(out_, strings.size());
    std::string bytes;
    for (const std::string& s : strings) {
      bytes += s;
      bytes += '\0';
    }
    if (format_ == VtkFormat::binary) {
      out_ += "\" format=\"appended\" offset=\"";
      text::append_integer(out_, appended_.size());
      out_ += "\"/>\n";
      append_little_endian<std::uint64_t>(appended_, bytes.size());
      appended_ += bytes;
      return;
    }
    out_ += "\" format=\"ascii\">\n          ";
    for (std::size_t k = 0; k < bytes.size(); ++k) {
      if (k > 0) out_ += ' ';
      text::append_integer(out_, static_cast<unsigned>(static_cast<unsigned char>(bytes[k])));
    }
    out_ += "\n        </DataArray>\n";
  }

  std::string finish() {
    out_ += "    </Piece>\n  </PolyData>\n";
    if (format_ == VtkFormat::binary) {
      out_ += "  <AppendedData encoding=\"raw\">\n   _";
      out_ += appended_;
      out_ += "\n  </AppendedData>\n";
    }
    out_ += "</VTKFile>\n";
    return std::move(out_);
  }

 private:
  void open_array(const char* type, const char* name, int components) {
    out_ += "        <DataArray type=\"";
    out_ += type;
    out_ += "\" Name=\"";
    out_ += name;
    out_ += '"';
    if (components != 1) {
      out_ += " NumberOfComponents=\"";
      text::append_integer(out_, components);
      out_ += '"';
    }
    if (format_ == VtkFormat::binary) {
      out_ += " format=\"appended\" offset=\"";
      text::append_integer(out_, appended_.size());
      out_ += "\"/>\n";
    } else {
      out_ += " format=\"ascii\">\n";
    }
  }

  VtkFormat format_;
  std::string out_;
  std::string appended_;  // binary: each array's UInt64 byte count, then its bytes
};

// The vector arrays' component c of entry i, or 0 when the optional array is empty.
double component(const std::vector<Eigen::Vector3d>& v, std::size_t i, int c) { return v.empty() ? 0.0 : v[i][c]; }

template <typename T>
T entry_or_zero(const std::vector<T>& v, std::size_t i) {
  return v.empty() ? T{0} : v[i];
}

void piece_header(PolyDataFile& file, std::size_t points, std::size_t verts, std::size_t lines, std::size_t polys) {
  file.put("    <Piece NumberOfPoints=\"");
  file.number(points);
  file.put("\" NumberOfVerts=\"");
  file.number(verts);
  file.put("\" NumberOfLines=\"");
  file.number(lines);
  file.put("\" NumberOfStrips=\"0\" NumberOfPolys=\"");
  file.number(polys);
  file.put("\">\n");
}

}  // namespace

const char* vtk_format_name(VtkFormat format) { return format == VtkFormat::ascii ? "ascii" : "binary"; }

void write_particles_vtp(const std::filesystem::path& path, const ParticleSnapshot& s, VtkFormat format) {
  const std::size_t n = s.id.size();
  const auto optional_fits = [n](std::size_t size) { return size == 0 || size == n; };
  if (s.position.size() != n || s.velocity.size() != n || s.radius.size() != n ||
      !optional_fits(s.angular_velocity.size()) || !optional_fits(s.level.size()) || !optional_fits(s.force.size()) ||
      !optional_fits(s.torque.size()) || !optional_fits(s.material.size()) || !optional_fits(s.coordination.size())) {
    throw std::invalid_argument("particle snapshot '" + path.string() + "': arrays differ in size from id (" +
                                std::to_string(n) + ")");
  }
  PolyDataFile file(format);
  if (!s.material_names.empty()) {
    file.put("    <FieldData>\n");
    file.string_array("material_names", s.material_names);
    file.put("    </FieldData>\n");
  }
  piece_header(file, n, n, 0, 0);
  file.put("      <PointData Scalars=\"radius\" Vectors=\"velocity\">\n");
  file.array<std::uint32_t>("UInt32", "id", 1, n, [&](std::size_t i, int) { return s.id[i]; });
  file.array<double>("Float64", "radius", 1, n, [&](std::size_t i, int) { return s.radius[i]; });
  file.array<double>("Float64", "velocity", 3, n, [&](std::size_t i, int c) { return s.velocity[i][c]; });
  file.array<double>("Float64", "angular_velocity", 3, n,
                     [&](std::size_t i, int c) { return component(s.angular_velocity, i, c); });
  file.array<std::int32_t>("Int32", "level", 1, n, [&](std::size_t i, int) { return entry_or_zero(s.level, i); });
  file.array<double>("Float64", "force", 3, n, [&](std::size_t i, int c) { return component(s.force, i, c); });
  file.array<double>("Float64", "torque", 3, n, [&](std::size_t i, int c) { return component(s.torque, i, c); });
  file.array<std::uint16_t>("UInt16", "material", 1, n,
                            [&](std::size_t i, int) { return entry_or_zero(s.material, i); });
  file.array<std::uint32_t>("UInt32", "coordination", 1, n,
                            [&](std::size_t i, int) { return entry_or_zero(s.coordination, i); });
  file.put("      </PointData>\n      <Points>\n");
  file.array<double>("Float64", "position", 3, n, [&](std::size_t i, int c) { return s.position[i][c]; });
  file.put("      </Points>\n      <Verts>\n");
  file.array<std::int64_t>("Int64", "connectivity", 1, n, [](std::size_t i, int) { return i; });
  file.array<std::int64_t>("Int64", "offsets", 1, n, [](std::size_t i, int) { return i + 1; });
  file.put("      </Verts>\n");
  write_file_atomically(path, file.finish());
}

void write_contacts_vtp(const std::filesystem::path& path, const ContactSnapshot& c, VtkFormat format) {
  const std::size_t n = c.size();
  if (c.from.size() != n || c.to.size() != n || c.id_b.size() != n || c.wall.size() != n ||
      c.normal_force.size() != n || c.normal_force_vector.size() != n || c.tangential_force_vector.size() != n ||
      c.overlap.size() != n) {
    throw std::invalid_argument("contact snapshot '" + path.string() + "': arrays differ in size from id_a (" +
                                std::to_string(n) + ")");
  }
  PolyDataFile file(format);
  piece_header(file, 2 * n, 0, n, 0);
  file.put("      <CellData Scalars=\"normal_force\" Vectors=\"normal_force_vector\">\n");
  file.array<std::int64_t>("Int64", "id_a", 1, n, [&](std::size_t k, int) { return c.id_a[k]; });
  file.array<std::int64_t>("Int64", "id_b", 1, n, [&](std::size_t k, int) { return c.id_b[k]; });
  file.array<std::int32_t>("Int32", "wall", 1, n, [&](std::size_t k, int) { return c.wall[k]; });
  file.array<double>("Float64", "normal_force", 1, n, [&](std::size_t k, int) { return c.normal_force[k]; });
  file.array<double>("Float64", "normal_force_vector", 3, n,
                     [&](std::size_t k, int i) { return c.normal_force_vector[k][i]; });
  file.array<double>("Float64", "tangential_force_vector", 3, n,
                     [&](std::size_t k, int i) { return c.tangential_force_vector[k][i]; });
  file.array<double>("Float64", "overlap", 1, n, [&](std::size_t k, int) { return c.overlap[k]; });
  file.put("      </CellData>\n      <Points>\n");
  file.array<double>("Float64", "position", 3, 2 * n, [&](std::size_t p, int i) {
    return p % 2 == 0 ? c.from[p / 2][i] : c.to[p / 2][i];
  });
  file.put("      </Points>\n      <Lines>\n");
  file.array<std::int64_t>("Int64", "connectivity", 1, 2 * n, [](std::size_t p, int) { return p; }, 2);
  file.array<std::int64_t>("Int64", "offsets", 1, n, [](std::size_t k, int) { return 2 * (k + 1); });
  file.put("      </Lines>\n");
  write_file_atomically(path, file.finish());
}

void write_walls_vtp(const std::filesystem::path& path, const WallGeometry& geometry, VtkFormat format) {
  const std::size_t point_count = geometry.points.size();
  const std::size_t triangle_count = geometry.triangles.size();
  if (geometry.wall_index.size() != triangle_count) {
    throw std::invalid_argument("wall geometry '" + path.string() + "': " + std::to_string(triangle_count) +
                                " triangles but " + std::to_string(geometry.wall_index.size()) + " wall indices");
  }
  for (std::size_t t = 0; t < triangle_count; ++t) {
    for (const std::uint32_t v : geometry.triangles[t]) {
      if (v >= point_count) {
        throw std::invalid_argument("wall geometry '" + path.string() + "': triangle " + std::to_string(t) +
                                    " refers to point " + std::to_string(v) + " of " + std::to_string(point_count));
      }
    }
  }
  PolyDataFile file(format);
  piece_header(file, point_count, 0, 0, triangle_count);
  file.put("      <CellData Scalars=\"wall\">\n");
  file.array<std::uint32_t>("UInt32", "wall", 1, triangle_count,
                            [&](std::size_t t, int) { return geometry.wall_index[t]; });
  file.put("      </CellData>\n      <Points>\n");
  file.array<double>("Float64", "position", 3, point_count,
                     [&](std::size_t i, int c) { return geometry.points[i][c]; });
  file.put("      </Points>\n      <Polys>\n");
  file.array<std::int64_t>(
      "Int64", "connectivity", 1, 3 * triangle_count,
      [&](std::size_t k, int) { return geometry.triangles[k / 3][k % 3]; }, 3);
  file.array<std::int64_t>("Int64", "offsets", 1, triangle_count, [](std::size_t t, int) { return 3 * (t + 1); });
  file.put("      </Polys>\n");
  write_file_atomically(path, file.finish());
}

// ---- .pvd ------------------------------------------------------------------------------------------

PvdIndex::PvdIndex(std::filesystem::path path) : path_(std::move(path)) {
  std::string contents;
  if (!read_whole_file(path_, contents)) return;
  if (contents.find("<VTKFile type=\"Collection\"") == std::string::npos ||
      contents.find("</VTKFile>") == std::string::npos) {
    throw std::runtime_error("'" + path_.string() + "' exists but is not a .pvd index written by dem");
  }
  std::size_t at = 0;
  while ((at = contents.find("<DataSet", at)) != std::string::npos) {
    const std::size_t end = contents.find("/>", at);
    if (end == std::string::npos) throw std::runtime_error("'" + path_.string() + "': unterminated DataSet");
    const std::string_view tag(contents.data() + at, end - at);
    std::string_view time_text, file_text;
    Entry entry{0, {}};
    if (!find_attribute(tag, "timestep", time_text) || !find_attribute(tag, "file", file_text) ||
        !text::parse_double(time_text, entry.time) || !xml_unescape(file_text, entry.file)) {
      throw std::runtime_error("'" + path_.string() + "': unreadable DataSet '" + std::string(tag) + "'");
    }
    entries_.push_back(std::move(entry));
    at = end;
  }
}

void PvdIndex::add(double time, const std::string& relative_file) {
  if (!std::isfinite(time)) throw std::invalid_argument("pvd '" + path_.string() + "': time is not finite");
  if (!entries_.empty() && !(time > entries_.back().time)) {
    throw std::invalid_argument("pvd '" + path_.string() + "': time " + std::to_string(time) +
                                " is not after the last entry's " + std::to_string(entries_.back().time));
  }
  if (relative_file.empty()) throw std::invalid_argument("pvd '" + path_.string() + "': empty file name");
  entries_.push_back({time, relative_file});
  try {
    write();
  } catch (...) {
    entries_.pop_back();  // keep the object equal to the file on disk
    throw;
  }
}

void PvdIndex::truncate_after(double time) {
  std::size_t keep = 0;
  while (keep < entries_.size() && entries_[keep].time <= time) ++keep;
  entries_.resize(keep);
  write();
}

void PvdIndex::write() const {
  std::string out =
      "<?xml version=\"1.0\"?>\n"
      "<VTKFile type=\"Collection\" version=\"1.0\" byte_order=\"LittleEndian\">\n"
      "  <Collection>\n";
  for (const Entry& entry : entries_) {
    out += "    <DataSet timestep=\"";
    text::append_double(out, entry.time);
    out += "\" group=\"\" part=\"0\" file=\"";
    out += xml_escape(entry.file);
    out += "\"/>\n";
  }
  out += "  </Collection>\n</VTKFile>\n";
  write_file_atomically(path_, out);
}

}  // namespace dem
