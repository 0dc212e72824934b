#pragma once
// The edge that writes result files: the series CSV, summary JSON, VTK snapshots and their .pvd index,
// and display geometry of the walls. No other engine file writes results.
//
// Durability: a whole file is written to `<path>.tmp.<pid>` in the same folder, fsync'ed and renamed over
// `<path>`, so a reader (or a crash) sees either the old or the new file, never a torn one. Series rows are
// appended, then fsync'ed, one row per output interval; a resume truncates them to the checkpoint's time.
// Numbers are written locale-independently as `%.17g` would (std::to_chars, 17 significant digits), so
// a double reads back bit-exactly with strtod.
// Threading: none of this is called from a parallel body; distinct objects may be used from distinct
// threads, one object from one thread at a time. Errors throw (std::runtime_error for I/O naming the path
// and the system's reason, std::invalid_argument for bad arguments); output runs between sync intervals,
// never inside a step.
#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include <Eigen/Core>

namespace dem {

/// Writes `contents` to `path` + ".tmp.<pid>", fsyncs it, renames it over `path` and fsyncs the folder
/// (best effort). The folder must exist. Throws std::runtime_error naming the path and errno text; on
/// failure the temporary file is removed and `path` is left as it was.
void write_file_atomically(const std::filesystem::path& path, const std::string& contents);

// ---------------------------------------------------------------------------------------------------
// Series CSV

/// Columns of `series.csv`, in order: time, energies, momentum, contacts, cost counters.
std::vector<std::string> series_columns();
/// Columns of the per-wall file: `time`, then `<name>_fx, _fy, _fz, _tx, _ty, _tz` for each wall, in order.
/// Columns of trajectories.csv: one row per particle and output time, in id order.
std::vector<std::string> trajectory_columns();
std::vector<std::string> wall_columns(const std::vector<std::string>& wall_names);

/// An append-only CSV whose first column is the time [s]. The header is written once, when the file is
/// created (atomically). Opening an existing file with the same header appends to it (resume); a torn last
/// line left by a crash is dropped on opening. A different header throws std::runtime_error.
class SeriesWriter {
 public:
  /// `columns`: non-empty names without ',', '"', CR or LF; the first one is the time.
  SeriesWriter(std::filesystem::path path, std::vector<std::string> columns);
  ~SeriesWriter();
  SeriesWriter(const SeriesWriter&) = delete;
  SeriesWriter& operator=(const SeriesWriter&) = delete;
  SeriesWriter(SeriesWriter&& other) noexcept;
  SeriesWriter& operator=(SeriesWriter&& other) noexcept;

  /// Appends one row (one value per column, `%.17g`; non-finite as nan/inf), then fsyncs.
  /// Throws std::invalid_argument if the row length differs from the column count.
  void append(const std::vector<double>& row);
  /// Rewrites the file atomically with the header and the rows whose time is <= `time` [s], in order.
  void truncate_after(double time);

  const std::filesystem::path& path() const { return path_; }
  const std::vector<std::string>& columns() const { return columns_; }

 private:
  void open_for_append();
  void close_file() noexcept;

  std::filesystem::path path_;
  std::vector<std::string> columns_;
  std::string header_;  // the columns joined by ',' plus '\n'
  int fd_ = -1;         // open O_APPEND while the object lives
};

// ---------------------------------------------------------------------------------------------------
// JSON (summary.json)

/// `s` with '"', '\\' and control characters (< 0x20) escaped for a JSON string (without the quotes).
/// Other bytes, UTF-8 included, pass through.
std::string json_escape(const std::string& s);

/// An ordered JSON object: keys keep insertion order, a duplicate key throws std::invalid_argument.
/// Doubles are written with 17 significant digits, non-finite ones as null (JSON has no NaN or inf).
class JsonObject {
 public:
  JsonObject& add(const std::string& key, double value);
  JsonObject& add(const std::string& key, std::int64_t value);
  JsonObject& add(const std::string& key, std::uint64_t value);
  JsonObject& add(const std::string& key, bool value);
  JsonObject& add(const std::string& key, std::string value);
  JsonObject& add(const std::string& key, const char* value) { return add(key, std::string(value)); }
  JsonObject& add(const std::string& key, JsonObject value);
  JsonObject& add(const std::string& key, std::vector<double> values);
  /// Any other integer type (int, unsigned, std::size_t...) goes to the 64-bit overload of its signedness.
  template <typename T>
    requires(std::is_integral_v<T> && !std::is_same_v<T, bool> && !std::is_same_v<T, std::int64_t> &&
             !std::is_same_v<T, std::uint64_t>)
  JsonObject& add(const std::string& key, T value) {
    if constexpr (std::is_signed_v<T>) {
      return add(key, static_cast<std::int64_t>(value));
    } else {
      return add(key, static_cast<std::uint64_t>(value));
    }
  }

  std::size_t size() const { return entries_.size(); }
  bool empty() const { return entries_.empty(); }

  /// The object as JSON text without a trailing newline. `indent` > 0: one key per line, nested by
  /// `indent` spaces, arrays on one line; `indent` <= 0: compact, no spaces.
  std::string dump(int indent = 2) const;

 private:
  using Value = std::variant<double, std::int64_t, std::uint64_t, bool, std::string,
                             std::shared_ptr<const JsonObject>, std::vector<double>>;
  JsonObject& insert(const std::string& key, Value value);
  void dump_to(std::string& out, int indent, int depth) const;

  std::vector<std::pair<std::string, Value>> entries_;  // nested objects are immutable once added
};

// ---------------------------------------------------------------------------------------------------
// VTK (XML PolyData, ASCII) and the .pvd time index

/// Particles at one time, in output order (usually ParticleId order). All arrays have the size of `id`,
/// except `angular_velocity` and `level`, which may be empty (written as zeros, so every snapshot has
/// the same arrays).
struct ParticleSnapshot {
  std::vector<std::uint32_t> id;
  std::vector<Eigen::Vector3d> position;          // [m]
  std::vector<Eigen::Vector3d> velocity;          // [m/s]
  std::vector<Eigen::Vector3d> angular_velocity;  // [rad/s]
  std::vector<double> radius;                     // [m]
  std::vector<std::int32_t> level;                // step = dt_base * 2^level
};

/// Writes `snapshot` as a VTK XML PolyData file: one point and one vertex cell per particle, PointData
/// `id` (UInt32), `radius` (Float64), `velocity`, `angular_velocity` (Float64 x3), `level` (Int32).
/// Atomic. Throws std::invalid_argument on inconsistent array sizes.
void write_particles_vtp(const std::filesystem::path& path, const ParticleSnapshot& snapshot);

/// Triangulated walls for display. `wall_index[k]` is the wall of triangle k.
struct WallGeometry {
  std::vector<Eigen::Vector3d> points;                   // [m]
  std::vector<std::array<std::uint32_t, 3>> triangles;   // indices into points, counterclockwise
  std::vector<std::uint32_t> wall_index;                 // one per triangle
};

/// Writes the triangles as Polys with a CellData `wall` (UInt32) array. Atomic. Throws
/// std::invalid_argument if an index is out of range or `wall_index` does not match `triangles`.
void write_walls_vtp(const std::filesystem::path& path, const WallGeometry& geometry);

/// Appends `part` to `into`, shifting its point indices.
void append_wall_geometry(WallGeometry& into, const WallGeometry& part);

/// A square of half side `half_size` [m] centred on `point`, in the plane of normal `normal`; 2 triangles
/// facing along `normal` (the particles' side).
WallGeometry plane_geometry(const Eigen::Vector3d& point, const Eigen::Vector3d& normal, double half_size,
                            std::uint32_t wall = 0);
/// A box: `center`, `half_extents` [m] along its own axes, turned by the proper rotation `rotation`
/// (the box axes are its columns); 8 points, 12 triangles facing outwards.
WallGeometry box_geometry(const Eigen::Vector3d& center, const Eigen::Vector3d& half_extents,
                          const Eigen::Matrix3d& rotation, std::uint32_t wall = 0);
/// The open side surface of a cylinder of `radius` [m] and finite `length` [m] centred on `point`
/// along `axis`; `segments` (>= 3) quads, 2 triangles each, facing the axis (the particles' side).
WallGeometry cylinder_geometry(const Eigen::Vector3d& point, const Eigen::Vector3d& axis, double radius,
                               double length, int segments = 64, std::uint32_t wall = 0);

/// A solid prism: the convex cross-section `corners` [m] (in order around it, in the plane through the
/// prism's centre) extruded by `length` [m] along `axis`, centred; side quads and two fan-capped ends.
WallGeometry prism_geometry(const std::vector<Eigen::Vector3d>& corners, const Eigen::Vector3d& axis, double length,
                            std::uint32_t wall = 0);

/// A ParaView collection (`.pvd`) listing snapshot files with their times; the whole file is rewritten
/// atomically on each change, so it is always valid. Opening an existing index keeps its entries
/// (resume); call truncate_after with the checkpoint's time to drop later ones.
class PvdIndex {
 public:
  /// Reads the entries of an existing index written by this class; throws std::runtime_error if the
  /// file exists but is not one.
  explicit PvdIndex(std::filesystem::path path);

  /// Adds a snapshot: `time` [s] finite and greater than the last entry's, `relative_file` relative to the
  /// .pvd's folder. Rewrites the file. Throws std::invalid_argument otherwise.
  void add(double time, const std::string& relative_file);
  /// Keeps the entries with time <= `time` [s] and rewrites the file.
  void truncate_after(double time);

  struct Entry {
    double time;  // [s]
    std::string file;
  };
  const std::vector<Entry>& entries() const { return entries_; }
  const std::filesystem::path& path() const { return path_; }

 private:
  void write() const;

  std::filesystem::path path_;
  std::vector<Entry> entries_;
};

}  // namespace dem
