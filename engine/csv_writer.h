#pragma once
// CSV result files: the append-only series (series.csv, walls.csv, trajectories.csv, the mill's rows)
// and the collision spectra table.
//
// Series rows are appended one write each, one row per output interval; a resume truncates them to the
// checkpoint's time. Numbers are written locale-independently with 17 significant digits, so a double
// reads back bit-exactly with strtod. Threading: distinct objects may be used from distinct threads, one
// object from one thread at a time; never called inside a step. Errors throw (std::runtime_error for
// I/O naming the path and the system's reason, std::invalid_argument for bad arguments).
#include <filesystem>
#include <string>
#include <vector>

namespace dem {

class CollisionSpectra;

/// Columns of `series.csv`, in order: time, energies, momentum, contacts, cost counters.
std::vector<std::string> series_columns();
/// Columns of trajectories.csv: one row per particle and output time, in id order.
std::vector<std::string> trajectory_columns();
/// Columns of the per-wall file: `time`, then `<name>_fx, _fy, _fz, _tx, _ty, _tz` for each wall, in order.
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

  /// Appends one row (one value per column, `%.17g`; non-finite as nan/inf).
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

/// The spectra's booked events as CSV: kind (ball-ball, ball-liner; with size classes c0-c1, c0-liner, ...), quantity (impact_energy,
/// normal_dissipated, tangential_dissipated: rolling included), bin_low, bin_high [J], events,
/// events_per_second (over `duration` [s]), energy [J] (the sum of the binned values); only bins with
/// events. Written atomically.
void write_spectra_csv(const std::filesystem::path& path, const CollisionSpectra& spectra, double duration);

}  // namespace dem
