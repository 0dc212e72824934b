#include "engine/output.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <string_view>
#include <system_error>

#include <Eigen/Geometry>

namespace dem {
namespace {

// ---- numbers and errors ----------------------------------------------------------------------------

std::string errno_text(int error) { return std::system_category().message(error); }

[[noreturn]] void throw_io(const std::string& what, const std::filesystem::path& path, int error) {
  throw std::runtime_error(what + " '" + path.string() + "': " + errno_text(error));
}

// Appends `value` as printf("%.17g") would in the C locale, whatever the program's locale.
void append_double(std::string& out, double value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value, std::chars_format::general, 17);
  out.append(buffer, result.ptr);
}

template <typename Int>
void append_integer(std::string& out, Int value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  out.append(buffer, result.ptr);
}

// Parses all of `text` as a double; false if it is not exactly one number.
bool parse_double(std::string_view text, double& value) {
  const auto result = std::from_chars(text.data(), text.data() + text.size(), value);
  return result.ec == std::errc() && result.ptr == text.data() + text.size();
}

// ---- POSIX file helpers ----------------------------------------------------------------------------

// Writes all of `data`, retrying partial writes and EINTR; returns 0 or an errno value.
int write_all(int fd, const char* data, std::size_t size) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    data += n;
    size -= static_cast<std::size_t>(n);
  }
  return 0;
}

// The whole file as a string; false if it does not exist; throws on other errors.
bool read_file(const std::filesystem::path& path, std::string& contents) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    if (errno == ENOENT) return false;
    throw_io("cannot open", path, errno);
  }
  contents.clear();
  char buffer[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int error = errno;
      ::close(fd);
      throw_io("cannot read", path, error);
    }
    if (n == 0) break;
    contents.append(buffer, static_cast<std::size_t>(n));
  }
  ::close(fd);
  return true;
}

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

// One <DataArray> with `count` tuples written by `put(out, i)`, each on its own line.
template <typename Put>
void append_data_array(std::string& out, const char* type, const char* name, int components, std::size_t count,
                       Put put) {
  out += "        <DataArray type=\"";
  out += type;
  out += "\" Name=\"";
  out += name;
  out += '"';
  if (components != 1) {
    out += " NumberOfComponents=\"";
    append_integer(out, components);
    out += '"';
  }
  out += " format=\"ascii\">\n";
  for (std::size_t i = 0; i < count; ++i) {
    out += "          ";
    put(out, i);
    out += '\n';
  }
  out += "        </DataArray>\n";
}

void append_vec3(std::string& out, const Eigen::Vector3d& v) {
  append_double(out, v.x());
  out += ' ';
  append_double(out, v.y());
  out += ' ';
  append_double(out, v.z());
}

constexpr const char* vtk_header =
    "<?xml version=\"1.0\"?>\n"
    "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n"
    "  <PolyData>\n";
constexpr const char* vtk_footer =
    "    </Piece>\n"
    "  </PolyData>\n"
    "</VTKFile>\n";

void check_finite_positive(double value, const char* what) {
  if (!std::isfinite(value) || value <= 0) {
    throw std::invalid_argument(std::string(what) + " must be finite and positive");
  }
}

Eigen::Vector3d unit_direction(const Eigen::Vector3d& v, const char* what) {
  const double norm = v.norm();
  if (!std::isfinite(norm) || norm == 0) {
    throw std::invalid_argument(std::string(what) + " must be a finite non-zero vector");
  }
  return v / norm;
}

}  // namespace

// ---- atomic whole-file write -----------------------------------------------------------------------

void write_file_atomically(const std::filesystem::path& path, const std::string& contents) {
  std::filesystem::path temporary = path;
  temporary += ".tmp." + std::to_string(::getpid());
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw_io("cannot create", temporary, errno);
  // Atomic against a crash of this process (the rename is all or nothing). No fsync: surviving a
  // power loss would cost tens of milliseconds per snapshot on ordinary disks.
  int error = write_all(fd, contents.data(), contents.size());
  if (::close(fd) != 0 && error == 0) error = errno;
  if (error != 0) {
    ::unlink(temporary.c_str());
    throw_io("cannot write", temporary, error);
  }
  if (std::rename(temporary.c_str(), path.c_str()) != 0) {
    error = errno;
    ::unlink(temporary.c_str());
    throw_io("cannot rename " + temporary.string() + " to", path, error);
  }
}

// ---- series ----------------------------------------------------------------------------------------

std::vector<std::string> series_columns() {
  return {"time",           "kinetic_energy", "rotational_energy", "potential_energy", "elastic_energy",
          "dissipated_energy", "momentum_x",  "momentum_y",        "momentum_z",       "contacts",
          "wall_contacts",  "sync_intervals", "accepted_steps",    "rejected_steps",   "forced_steps",
          "particle_steps", "force_evaluations", "pair_rebuilds",  "round_redos",      "finest_level",
          "coarsest_level"};
}

std::vector<std::string> trajectory_columns() {
  return {"time", "id", "x", "y", "z", "vx", "vy", "vz", "wx", "wy", "wz"};
}

std::vector<std::string> wall_columns(const std::vector<std::string>& wall_names) {
  std::vector<std::string> columns{"time"};
  for (const std::string& name : wall_names) {
    for (const char* suffix : {"_fx", "_fy", "_fz", "_tx", "_ty", "_tz"}) columns.push_back(name + suffix);
  }
  return columns;
}

SeriesWriter::SeriesWriter(std::filesystem::path path, std::vector<std::string> columns)
    : path_(std::move(path)), columns_(std::move(columns)) {
  if (columns_.empty()) throw std::invalid_argument("series '" + path_.string() + "': no columns");
  for (const std::string& column : columns_) {
    if (column.empty() || column.find_first_of(",\"\r\n") != std::string::npos) {
      throw std::invalid_argument("series '" + path_.string() + "': column name '" + column +
                                  "' is empty or holds one of , \" CR LF");
    }
    if (!header_.empty()) header_ += ',';
    header_ += column;
  }
  header_ += '\n';

  std::string contents;
  const bool exists = read_file(path_, contents);
  if (!exists || contents.empty()) {
    write_file_atomically(path_, header_);
  } else {
    const std::size_t first_end = contents.find('\n');
    if (first_end == std::string::npos) {
      // No complete line: only a torn copy of our own header is acceptable.
      if (header_.compare(0, contents.size(), contents) != 0) {
        throw std::runtime_error("series '" + path_.string() + "' has a different header: expected '" +
                                 header_.substr(0, header_.size() - 1) + "', found '" + contents + "'");
      }
      write_file_atomically(path_, header_);
    } else {
      if (contents.compare(0, first_end + 1, header_) != 0) {
        throw std::runtime_error("series '" + path_.string() + "' has a different header: expected '" +
                                 header_.substr(0, header_.size() - 1) + "', found '" +
                                 contents.substr(0, first_end) + "'");
      }
      if (contents.back() != '\n') {
        // A row torn by a crash: drop it so the next row starts on a fresh line.
        contents.resize(contents.rfind('\n') + 1);
        write_file_atomically(path_, contents);
      }
    }
  }
  open_for_append();
}

SeriesWriter::~SeriesWriter() { close_file(); }

SeriesWriter::SeriesWriter(SeriesWriter&& other) noexcept
    : path_(std::move(other.path_)),
      columns_(std::move(other.columns_)),
      header_(std::move(other.header_)),
      fd_(std::exchange(other.fd_, -1)) {}

SeriesWriter& SeriesWriter::operator=(SeriesWriter&& other) noexcept {
  if (this != &other) {
    close_file();
    path_ = std::move(other.path_);
    columns_ = std::move(other.columns_);
    header_ = std::move(other.header_);
    fd_ = std::exchange(other.fd_, -1);
  }
  return *this;
}

void SeriesWriter::open_for_append() {
  fd_ = ::open(path_.c_str(), O_WRONLY | O_APPEND | O_CLOEXEC);
  if (fd_ < 0) throw_io("cannot open for appending", path_, errno);
}

void SeriesWriter::close_file() noexcept {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

void SeriesWriter::append(const std::vector<double>& row) {
  if (row.size() != columns_.size()) {
    throw std::invalid_argument("series '" + path_.string() + "': row of " + std::to_string(row.size()) +
                                " values for " + std::to_string(columns_.size()) + " columns");
  }
  if (fd_ < 0) throw std::logic_error("series '" + path_.string() + "': writer was moved from");
  std::string line;
  line.reserve(row.size() * 24);
  for (std::size_t c = 0; c < row.size(); ++c) {
    if (c > 0) line += ',';
    append_double(line, row[c]);
  }
  line += '\n';
  // One write of the whole line (O_APPEND): once write() returns the row survives a crash of this
  // process (a torn last line is dropped on reopening). No fsync per row: rows come every output
  // interval and an fsync each would cost more than the physics of small scenes.
  if (const int error = write_all(fd_, line.data(), line.size()); error != 0) {
    throw_io("cannot append to", path_, error);
  }
}

void SeriesWriter::truncate_after(double time) {
  std::string contents;
  if (!read_file(path_, contents)) throw_io("cannot read", path_, ENOENT);
  std::string kept = header_;
  std::size_t line_number = 1;
  std::size_t begin = contents.find('\n');
  begin = begin == std::string::npos ? contents.size() : begin + 1;
  while (begin < contents.size()) {
    ++line_number;
    std::size_t end = contents.find('\n', begin);
    if (end == std::string::npos) break;  // a torn last row is dropped
    const std::string_view line(contents.data() + begin, end - begin);
    const std::string_view first = line.substr(0, line.find(','));
    double row_time = 0;
    if (!parse_double(first, row_time)) {
      throw std::runtime_error("series '" + path_.string() + "' line " + std::to_string(line_number) +
                               ": first column '" + std::string(first) + "' is not a time");
    }
    if (row_time <= time) {
      kept.append(line);
      kept += '\n';
    }
    begin = end + 1;
  }
  write_file_atomically(path_, kept);
  // The rename replaced the file: the open descriptor still points at the old one.
  close_file();
  open_for_append();
}

// ---- JSON ------------------------------------------------------------------------------------------

std::string json_escape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (const char c : s) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\b': out += "\\b"; break;
      case '\f': out += "\\f"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          static constexpr char hex[] = "0123456789abcdef";
          out += "\\u00";
          out += hex[(static_cast<unsigned char>(c) >> 4) & 0xf];
          out += hex[static_cast<unsigned char>(c) & 0xf];
        } else {
          out += c;
        }
    }
  }
  return out;
}

JsonObject& JsonObject::insert(const std::string& key, Value value) {
  for (const auto& entry : entries_) {
    if (entry.first == key) throw std::invalid_argument("JSON object: duplicate key '" + key + "'");
  }
  entries_.emplace_back(key, std::move(value));
  return *this;
}

JsonObject& JsonObject::add(const std::string& key, double value) { return insert(key, value); }
JsonObject& JsonObject::add(const std::string& key, std::int64_t value) { return insert(key, value); }
JsonObject& JsonObject::add(const std::string& key, std::uint64_t value) { return insert(key, value); }
JsonObject& JsonObject::add(const std::string& key, bool value) { return insert(key, value); }
JsonObject& JsonObject::add(const std::string& key, std::string value) { return insert(key, std::move(value)); }
JsonObject& JsonObject::add(const std::string& key, JsonObject value) {
  return insert(key, std::make_shared<const JsonObject>(std::move(value)));
}
JsonObject& JsonObject::add(const std::string& key, std::vector<double> values) {
  return insert(key, std::move(values));
}

std::string JsonObject::dump(int indent) const {
  std::string out;
  dump_to(out, indent < 0 ? 0 : indent, 0);
  return out;
}

void JsonObject::dump_to(std::string& out, int indent, int depth) const {
  const auto append_number = [&out](double v) {
    if (std::isfinite(v)) {
      append_double(out, v);
    } else {
      out += "null";
    }
  };
  if (entries_.empty()) {
    out += "{}";
    return;
  }
  const bool pretty = indent > 0;
  const std::string inner(pretty ? static_cast<std::size_t>(indent) * (depth + 1) : 0, ' ');
  out += '{';
  for (std::size_t k = 0; k < entries_.size(); ++k) {
    const auto& [key, value] = entries_[k];
    if (k > 0) out += ',';
    if (pretty) {
      out += '\n';
      out += inner;
    }
    out += '"';
    out += json_escape(key);
    out += pretty ? "\": " : "\":";
    if (const auto* d = std::get_if<double>(&value)) {
      append_number(*d);
    } else if (const auto* i = std::get_if<std::int64_t>(&value)) {
      append_integer(out, *i);
    } else if (const auto* u = std::get_if<std::uint64_t>(&value)) {
      append_integer(out, *u);
    } else if (const auto* b = std::get_if<bool>(&value)) {
      out += *b ? "true" : "false";
    } else if (const auto* s = std::get_if<std::string>(&value)) {
      out += '"';
      out += json_escape(*s);
      out += '"';
    } else if (const auto* o = std::get_if<std::shared_ptr<const JsonObject>>(&value)) {
      (*o)->dump_to(out, indent, depth + 1);
    } else {
      const auto& array = std::get<std::vector<double>>(value);
      out += '[';
      for (std::size_t j = 0; j < array.size(); ++j) {
        if (j > 0) out += pretty ? ", " : ",";
        append_number(array[j]);
      }
      out += ']';
    }
  }
  if (pretty) {
    out += '\n';
    out.append(static_cast<std::size_t>(indent) * depth, ' ');
  }
  out += '}';
}

// ---- VTK -------------------------------------------------------------------------------------------

void write_particles_vtp(const std::filesystem::path& path, const ParticleSnapshot& snapshot) {
  const std::size_t n = snapshot.id.size();
  const bool have_spin = !snapshot.angular_velocity.empty();
  const bool have_level = !snapshot.level.empty();
  if (snapshot.position.size() != n || snapshot.velocity.size() != n || snapshot.radius.size() != n ||
      (have_spin && snapshot.angular_velocity.size() != n) || (have_level && snapshot.level.size() != n)) {
    throw std::invalid_argument("particle snapshot '" + path.string() +
                                "': arrays differ in size from id (" + std::to_string(n) + ")");
  }
  std::string out;
  out.reserve(256 + n * 260);
  out += vtk_header;
  out += "    <Piece NumberOfPoints=\"";
  append_integer(out, n);
  out += "\" NumberOfVerts=\"";
  append_integer(out, n);
  out += "\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"0\">\n";
  out += "      <PointData Scalars=\"radius\" Vectors=\"velocity\">\n";
  append_data_array(out, "UInt32", "id", 1, n,
                    [&](std::string& o, std::size_t i) { append_integer(o, snapshot.id[i]); });
  append_data_array(out, "Float64", "radius", 1, n,
                    [&](std::string& o, std::size_t i) { append_double(o, snapshot.radius[i]); });
  append_data_array(out, "Float64", "velocity", 3, n,
                    [&](std::string& o, std::size_t i) { append_vec3(o, snapshot.velocity[i]); });
  append_data_array(out, "Float64", "angular_velocity", 3, n, [&](std::string& o, std::size_t i) {
    append_vec3(o, have_spin ? snapshot.angular_velocity[i] : Eigen::Vector3d::Zero().eval());
  });
  append_data_array(out, "Int32", "level", 1, n, [&](std::string& o, std::size_t i) {
    append_integer(o, have_level ? snapshot.level[i] : std::int32_t{0});
  });
  out += "      </PointData>\n";
  out += "      <Points>\n";
  append_data_array(out, "Float64", "position", 3, n,
                    [&](std::string& o, std::size_t i) { append_vec3(o, snapshot.position[i]); });
  out += "      </Points>\n";
  out += "      <Verts>\n";
  append_data_array(out, "Int64", "connectivity", 1, n, [](std::string& o, std::size_t i) { append_integer(o, i); });
  append_data_array(out, "Int64", "offsets", 1, n, [](std::string& o, std::size_t i) { append_integer(o, i + 1); });
  out += "      </Verts>\n";
  out += vtk_footer;
  write_file_atomically(path, out);
}

void write_walls_vtp(const std::filesystem::path& path, const WallGeometry& geometry) {
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
  std::string out;
  out.reserve(256 + point_count * 80 + triangle_count * 60);
  out += vtk_header;
  out += "    <Piece NumberOfPoints=\"";
  append_integer(out, point_count);
  out += "\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"";
  append_integer(out, triangle_count);
  out += "\">\n";
  out += "      <CellData Scalars=\"wall\">\n";
  append_data_array(out, "UInt32", "wall", 1, triangle_count,
                    [&](std::string& o, std::size_t t) { append_integer(o, geometry.wall_index[t]); });
  out += "      </CellData>\n";
  out += "      <Points>\n";
  append_data_array(out, "Float64", "position", 3, point_count,
                    [&](std::string& o, std::size_t i) { append_vec3(o, geometry.points[i]); });
  out += "      </Points>\n";
  out += "      <Polys>\n";
  append_data_array(out, "Int64", "connectivity", 1, triangle_count, [&](std::string& o, std::size_t t) {
    const auto& tri = geometry.triangles[t];
    append_integer(o, tri[0]);
    o += ' ';
    append_integer(o, tri[1]);
    o += ' ';
    append_integer(o, tri[2]);
  });
  append_data_array(out, "Int64", "offsets", 1, triangle_count,
                    [](std::string& o, std::size_t t) { append_integer(o, 3 * (t + 1)); });
  out += "      </Polys>\n";
  out += vtk_footer;
  write_file_atomically(path, out);
}

void append_wall_geometry(WallGeometry& into, const WallGeometry& part) {
  const auto offset = static_cast<std::uint32_t>(into.points.size());
  into.points.insert(into.points.end(), part.points.begin(), part.points.end());
  for (const auto& tri : part.triangles) into.triangles.push_back({tri[0] + offset, tri[1] + offset, tri[2] + offset});
  into.wall_index.insert(into.wall_index.end(), part.wall_index.begin(), part.wall_index.end());
}

WallGeometry plane_geometry(const Eigen::Vector3d& point, const Eigen::Vector3d& normal, double half_size,
                            std::uint32_t wall) {
  check_finite_positive(half_size, "plane_geometry: half_size");
  const Eigen::Vector3d n = unit_direction(normal, "plane_geometry: normal");
  // (u, v, n) right-handed, so the counterclockwise corners below face along n.
  const Eigen::Vector3d u = n.unitOrthogonal() * half_size;
  const Eigen::Vector3d v = n.cross(n.unitOrthogonal()) * half_size;
  WallGeometry g;
  g.points = {point - u - v, point + u - v, point + u + v, point - u + v};
  g.triangles = {{0, 1, 2}, {0, 2, 3}};
  g.wall_index = {wall, wall};
  return g;
}

WallGeometry box_geometry(const Eigen::Vector3d& center, const Eigen::Vector3d& half_extents,
                          const Eigen::Matrix3d& rotation, std::uint32_t wall) {
  for (int a = 0; a < 3; ++a) check_finite_positive(half_extents[a], "box_geometry: half_extents");
  if (!rotation.allFinite() || (rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).norm() > 1e-9 ||
      rotation.determinant() <= 0) {
    throw std::invalid_argument("box_geometry: rotation must be a proper rotation matrix (orthonormal, det +1)");
  }
  WallGeometry g;
  // Corner k has sign + along axis a when bit a of k is set.
  for (std::uint32_t k = 0; k < 8; ++k) {
    Eigen::Vector3d local;
    for (int a = 0; a < 3; ++a) local[a] = ((k >> a) & 1U) != 0 ? half_extents[a] : -half_extents[a];
    g.points.push_back(center + rotation * local);
  }
  // Face of axis a, side s: corners ordered (b, c) = (0,0), (1,0), (1,1), (0,1) with b, c the next axes in
  // cyclic order face along e_b x e_c = e_a; the side s = 0 is reversed to face along -e_a.
  for (std::uint32_t a = 0; a < 3; ++a) {
    const std::uint32_t b = (a + 1) % 3;
    const std::uint32_t c = (a + 2) % 3;
    for (std::uint32_t s = 0; s < 2; ++s) {
      const std::uint32_t base = s << a;
      const std::array<std::uint32_t, 4> quad = {base, base | (1U << b), base | (1U << b) | (1U << c),
                                                 base | (1U << c)};
      if (s == 1) {
        g.triangles.push_back({quad[0], quad[1], quad[2]});
        g.triangles.push_back({quad[0], quad[2], quad[3]});
      } else {
        g.triangles.push_back({quad[0], quad[2], quad[1]});
        g.triangles.push_back({quad[0], quad[3], quad[2]});
      }
    }
  }
  g.wall_index.assign(g.triangles.size(), wall);
  return g;
}

WallGeometry prism_geometry(const std::vector<Eigen::Vector3d>& corners, const Eigen::Vector3d& axis, double length,
                            std::uint32_t wall) {
  check_finite_positive(length, "prism_geometry: length (give a finite display length)");
  if (corners.size() < 3) throw std::invalid_argument("prism_geometry: at least 3 corners");
  const Eigen::Vector3d half = 0.5 * length * unit_direction(axis, "prism_geometry: axis");
  const auto n = static_cast<std::uint32_t>(corners.size());
  WallGeometry g;
  for (const auto& c : corners) g.points.push_back(c - half);  // points 0 .. n-1: the back end
  for (const auto& c : corners) g.points.push_back(c + half);  // n .. 2n-1: the front end
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint32_t j = (i + 1) % n;
    g.triangles.push_back({i, j, n + j});
    g.triangles.push_back({i, n + j, n + i});
  }
  for (std::uint32_t i = 1; i + 1 < n; ++i) {
    g.triangles.push_back({0, i + 1, i});
    g.triangles.push_back({n, n + i, n + i + 1});
  }
  g.wall_index.assign(g.triangles.size(), wall);
  return g;
}

WallGeometry cylinder_geometry(const Eigen::Vector3d& point, const Eigen::Vector3d& axis, double radius,
                               double length, int segments, std::uint32_t wall) {
  check_finite_positive(radius, "cylinder_geometry: radius");
  check_finite_positive(length, "cylinder_geometry: length (give a finite display length)");
  if (segments < 3) throw std::invalid_argument("cylinder_geometry: segments must be at least 3");
  const Eigen::Vector3d a = unit_direction(axis, "cylinder_geometry: axis");
  const Eigen::Vector3d u = a.unitOrthogonal();
  const Eigen::Vector3d v = a.cross(u);  // (u, v, a) right-handed
  const Eigen::Vector3d half = a * (0.5 * length);
  const auto m = static_cast<std::uint32_t>(segments);
  WallGeometry g;
  g.points.reserve(2 * m);
  for (std::uint32_t i = 0; i < m; ++i) {
    const double angle = 2 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(m);
    const Eigen::Vector3d radial = (std::cos(angle) * u + std::sin(angle) * v) * radius;
    g.points.push_back(point - half + radial);  // 2i: bottom
    g.points.push_back(point + half + radial);  // 2i + 1: top
  }
  // Bottom b_i, top t_i; (b_i, t_i, t_{i+1}) and (b_i, t_{i+1}, b_{i+1}) face the axis.
  for (std::uint32_t i = 0; i < m; ++i) {
    const std::uint32_t j = (i + 1) % m;
    g.triangles.push_back({2 * i, 2 * i + 1, 2 * j + 1});
    g.triangles.push_back({2 * i, 2 * j + 1, 2 * j});
  }
  g.wall_index.assign(g.triangles.size(), wall);
  return g;
}

// ---- .pvd ------------------------------------------------------------------------------------------

PvdIndex::PvdIndex(std::filesystem::path path) : path_(std::move(path)) {
  std::string contents;
  if (!read_file(path_, contents)) return;
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
        !parse_double(time_text, entry.time) || !xml_unescape(file_text, entry.file)) {
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
    append_double(out, entry.time);
    out += "\" group=\"\" part=\"0\" file=\"";
    out += xml_escape(entry.file);
    out += "\"/>\n";
  }
  out += "  </Collection>\n</VTKFile>\n";
  write_file_atomically(path_, out);
}

}  // namespace dem
