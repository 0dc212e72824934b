#pragma once
// What the `dem trade` tests share: run the program from the source root as a user would, in a fresh
// folder per test, and read the CSV files it writes.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "tests/cli_support.h"

namespace dem::test::trade_cli {

using cli::read_text;
using cli::Result;
using cli::source_dir;
using cli::TempDir;
namespace fs = std::filesystem;

/// Runs `dem trade <args>` from the source root (so scenes/... resolve); stdout and stderr captured.
inline Result trade(const std::string& args, const TempDir& dir) {
  return cli::run_dem_shell("trade " + args, dir.path(), source_dir);
}

struct Csv {
  std::vector<std::string> header;
  std::vector<std::map<std::string, std::string>> rows;
  double number(std::size_t row, const std::string& column) const {
    const std::string& text = rows.at(row).at(column);
    if (text == "inf") return INFINITY;
    return std::stod(text);
  }
};

inline std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, ',')) out.push_back(field);
  if (!line.empty() && line.back() == ',') out.emplace_back();
  return out;
}

inline Csv read_csv(const fs::path& path) {
  Csv csv;
  std::ifstream in(path);
  std::string line;
  if (!std::getline(in, line)) return csv;
  csv.header = split(line);
  while (std::getline(in, line)) {
    const std::vector<std::string> f = split(line);
    std::map<std::string, std::string> row;
    for (std::size_t k = 0; k < csv.header.size(); ++k) row[csv.header[k]] = k < f.size() ? f[k] : "";
    csv.rows.push_back(row);
  }
  return csv;
}

}  // namespace dem::test::trade_cli
