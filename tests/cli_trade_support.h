#pragma once
// What the `dem trade` tests share: run the program from the source root as a user would, in a fresh
// folder per test, and read the CSV files it writes.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#ifndef DEM_PROGRAM
#error "DEM_PROGRAM (path of the dem executable) must be defined by tests/CMakeLists.txt"
#endif
#ifndef DEM_SOURCE_DIR
#error "DEM_SOURCE_DIR (the repository root) must be defined by tests/CMakeLists.txt"
#endif

namespace dem::test::trade_cli {

namespace fs = std::filesystem;

inline const fs::path source_dir{DEM_SOURCE_DIR};

inline std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

struct Result {
  int code = -1;
  std::string out, err;
};

/// A fresh folder per test, removed afterwards.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() /
            ("dem_cli_trade_test_" + std::to_string(::getpid()) + "_" + info->test_suite_name() + "_" + info->name());
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

/// Runs `dem trade <args>` from the source root (so scenes/... resolve); stdout and stderr captured.
inline Result trade(const std::string& args, const TempDir& dir) {
  const fs::path out = dir.path() / "stdout.txt", err = dir.path() / "stderr.txt";
  const std::string command = "cd '" + source_dir.string() + "' && '" + std::string(DEM_PROGRAM) + "' trade " + args +
                              " >'" + out.string() + "' 2>'" + err.string() + "'";
  const int status = std::system(command.c_str());
  Result r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = read_text(out);
  r.err = read_text(err);
  return r;
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
