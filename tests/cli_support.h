#pragma once
// What the tests of the `dem` program (tests/cli_*) share: a fresh folder per test, running the
// program and capturing its exit code, stdout and stderr, and reading the files it writes.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#ifndef DEM_PROGRAM
#error "DEM_PROGRAM (path of the dem executable) must be defined by tests/CMakeLists.txt"
#endif
#ifndef DEM_SOURCE_DIR
#error "DEM_SOURCE_DIR (the repository root) must be defined by tests/CMakeLists.txt"
#endif

namespace dem::test::cli {

namespace fs = std::filesystem;

inline const fs::path source_dir{DEM_SOURCE_DIR};

/// The whole file (empty when it cannot be read).
inline std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

inline void write_text(const fs::path& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

/// `s` quoted for the shell.
inline std::string quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) {
    if (c == '\'') {
      q.append("'\\''");
    } else {
      q.push_back(c);
    }
  }
  q.push_back('\'');
  return q;
}

/// The exit code of a std::system status; -1 when the program did not exit normally (a crash).
inline int exit_code(int status) { return status != -1 && WIFEXITED(status) ? WEXITSTATUS(status) : -1; }

/// A fresh folder, removed afterwards: named after the running test, or after `name`.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = std::string(info->test_suite_name()) + "_" + info->name();
    std::replace_if(name.begin(), name.end(), [](char c) { return !std::isalnum(static_cast<unsigned char>(c)); }, '_');
    make(name);
  }
  explicit TempDir(const std::string& name) { make(name); }
  ~TempDir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const fs::path& path() const { return path_; }

 private:
  void make(const std::string& name) {
    path_ = fs::temp_directory_path() / ("dem_cli_" + std::to_string(::getpid()) + "_" + name);
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  fs::path path_;
};

struct Result {
  int code = -1;  // exit code; -1 when the program did not exit normally (a crash)
  std::string out, err;
};

/// Runs `dem` with the shell text `arguments` from folder `cwd` (the current one when empty),
/// capturing stdout and stderr in files under `scratch`.
inline Result run_dem_shell(const std::string& arguments, const fs::path& scratch, const fs::path& cwd = {}) {
  const fs::path out = scratch / "stdout.txt", err = scratch / "stderr.txt";
  std::string command;
  if (!cwd.empty()) command.append("cd ").append(quote(cwd.string())).append(" && ");
  command.append(quote(DEM_PROGRAM)).append(" ").append(arguments);  // (no operator+ chains: g++ 12 -Wrestrict)
  command.append(" > ").append(quote(out.string())).append(" 2> ").append(quote(err.string()));
  Result r;
  r.code = exit_code(std::system(command.c_str()));
  r.out = read_text(out);
  r.err = read_text(err);
  return r;
}

/// Runs `dem` with `args` (each quoted), capturing stdout and stderr in files under `scratch`.
inline Result run_dem(const std::vector<std::string>& args, const fs::path& scratch) {
  std::string arguments;
  for (const std::string& a : args) arguments.append(arguments.empty() ? "" : " ").append(quote(a));
  return run_dem_shell(arguments, scratch);
}

/// Runs `dem` with the shell text `arguments` (redirections included, if any); its exit code.
inline int run_dem_status(const std::string& arguments) {
  const std::string command = quote(DEM_PROGRAM) + " " + arguments;
  return exit_code(std::system(command.c_str()));
}

/// A JSON value as the program writes them (summary.json).
struct Json {
  enum class Kind { null, boolean, number, string, array, object } kind = Kind::null;
  bool boolean = false;
  double number = 0;
  std::string string;
  std::vector<Json> array;
  // An object's members: keys[i] names values[i] (not a vector of pairs: clang with libstdc++ wants
  // pair<string, Json> complete inside Json).
  std::vector<std::string> keys;
  std::vector<Json> values;

  bool has(const std::string& key) const { return std::find(keys.begin(), keys.end(), key) != keys.end(); }
  const Json& operator[](const std::string& key) const {
    for (std::size_t i = 0; i < keys.size(); ++i)
      if (keys[i] == key) return values[i];
    static const Json missing;
    return missing;
  }
};

/// A strict reader for the JSON the program writes; `ok` turns false on any syntax error.
class JsonReader {
 public:
  explicit JsonReader(std::string text) : text_(std::move(text)) {}

  Json parse() {
    Json v = value();
    space();
    if (at_ != text_.size()) ok = false;
    return v;
  }
  bool ok = true;

 private:
  void space() {
    while (at_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[at_]))) ++at_;
  }
  bool eat(char c) {
    space();
    if (at_ < text_.size() && text_[at_] == c) return ++at_, true;
    return false;
  }
  bool word(const char* w) {
    const std::size_t n = std::char_traits<char>::length(w);
    if (text_.compare(at_, n, w) != 0) return false;
    at_ += n;
    return true;
  }
  std::string string_literal() {
    std::string s;
    if (!eat('"')) return ok = false, s;
    while (at_ < text_.size() && text_[at_] != '"') {
      char c = text_[at_++];
      if (c == '\\' && at_ < text_.size()) {
        const char e = text_[at_++];
        c = e == 'n' ? '\n' : e == 't' ? '\t' : e == 'r' ? '\r' : e;
        if (e == 'u') at_ += 4, c = '?';
      }
      s += c;
    }
    if (at_ >= text_.size()) return ok = false, s;
    ++at_;
    return s;
  }
  Json value() {
    Json v;
    space();
    if (at_ >= text_.size()) return ok = false, v;
    const char c = text_[at_];
    if (c == '{') {
      v.kind = Json::Kind::object;
      ++at_;
      if (eat('}')) return v;
      do {
        std::string key = string_literal();
        if (!eat(':')) ok = false;
        v.keys.push_back(std::move(key));
        v.values.push_back(value());
      } while (ok && eat(','));
      if (!eat('}')) ok = false;
    } else if (c == '[') {
      v.kind = Json::Kind::array;
      ++at_;
      if (eat(']')) return v;
      do v.array.push_back(value());
      while (ok && eat(','));
      if (!eat(']')) ok = false;
    } else if (c == '"') {
      v.kind = Json::Kind::string;
      v.string = string_literal();
    } else if (word("true") || word("false")) {
      v.kind = Json::Kind::boolean;
      v.boolean = c == 't';
    } else if (word("null")) {
      v.kind = Json::Kind::null;
    } else {
      char* end = nullptr;
      v.kind = Json::Kind::number;
      v.number = std::strtod(text_.c_str() + at_, &end);
      if (end == text_.c_str() + at_) ok = false;
      at_ = static_cast<std::size_t>(end - text_.c_str());
    }
    return v;
  }

  std::string text_;
  std::size_t at_ = 0;
};

/// summary.json and other JSON files of the program; a test failure when not valid JSON.
inline Json read_json(const fs::path& path) {
  JsonReader reader(read_text(path));
  Json j = reader.parse();
  EXPECT_TRUE(reader.ok) << path << " is not valid JSON";
  return j;
}

/// The string value of `"key": "..."` in a summary.json (the first such key); empty when absent.
inline std::string summary_string(const fs::path& summary, const std::string& key) {
  const std::string text = read_text(summary);
  const std::string pattern = "\"" + key + "\": \"";
  const auto at = text.find(pattern);
  if (at == std::string::npos) return "";
  const auto start = at + pattern.size();
  return text.substr(start, text.find('"', start) - start);
}

/// The checkpoint files (*.bin) in a run's output folder.
inline std::vector<fs::path> checkpoints_in(const fs::path& dir) {
  std::vector<fs::path> found;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".bin") found.push_back(e.path());
  return found;
}

}  // namespace dem::test::cli
