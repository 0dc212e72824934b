#include "engine/csv_writer.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string_view>
#include <utility>

#include "engine/atomic_file.h"
#include "engine/collision_spectra.h"
#include "engine/number_text.h"

namespace dem {

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
  const bool exists = read_whole_file(path_, contents);
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
    text::append_double(line, row[c]);
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
  if (!read_whole_file(path_, contents)) throw_io("cannot read", path_, ENOENT);
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
    if (!text::parse_double(first, row_time)) {
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

void write_spectra_csv(const std::filesystem::path& path, const CollisionSpectra& spectra, double duration) {
  using S = CollisionSpectra;
  std::string text = "kind,quantity,bin_low,bin_high,events,events_per_second,energy\n";
  char line[256];
  for (S::Kind k = 0; k < spectra.kind_count(); ++k) {
    const std::string kind = spectra.kind_name(k);
    for (int q = 0; q < S::quantity_count; ++q)
      for (int b = 0; b < S::bin_count; ++b) {
        const auto quantity = static_cast<S::Quantity>(q);
        const std::uint64_t count = spectra.count(k, quantity, b);
        if (count == 0) continue;
        std::snprintf(line, sizeof line, "%s,%s,%.6g,%.6g,%llu,%.17g,%.17g\n", kind.c_str(),
                      S::quantity_names[q], b == 0 ? 0.0 : S::bin_low(b),
                      b == S::bin_count - 1 ? INFINITY : S::bin_low(b + 1), static_cast<unsigned long long>(count),
                      duration > 0 ? static_cast<double>(count) / duration : 0.0, spectra.energy(k, quantity, b));
        text += line;
      }
  }
  write_file_atomically(path, text);
}

}  // namespace dem
