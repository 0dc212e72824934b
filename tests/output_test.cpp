// Tests of the result writers (atomic_file.h, csv_writer.h, json_writer.h, vtk_writer.h, wall_geometry.h):
// atomic whole-file writes, the series CSV (bit-exact round trip, resume,
// truncation), the JSON builder, VTK PolyData snapshots and walls, and the .pvd index.
// Oracles: files are read back by independent readers written here (a small XML parser, a small JSON
// parser, strtod), never compared with strings produced by the code under test; wall geometry is checked
// against closed forms (areas, distances, facing sides).
#include "engine/atomic_file.h"
#include "engine/csv_writer.h"
#include "engine/json_writer.h"
#include "engine/vtk_writer.h"
#include "engine/wall_geometry.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Geometry>

namespace dem {
namespace {

namespace fs = std::filesystem;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool same_bits(double a, double b) { return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b); }

// Parses all of `text` as a double with strtod (the C library, independent of the writer's to_chars).
double parse_double(const std::string& text) {
  if (text.empty()) throw std::runtime_error("empty number");
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size()) throw std::runtime_error("not a number: '" + text + "'");
  return value;
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + path.string());
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

std::vector<std::string> split(const std::string& text, char separator) {
  std::vector<std::string> parts;
  std::size_t begin = 0;
  for (;;) {
    const std::size_t end = text.find(separator, begin);
    parts.push_back(text.substr(begin, end == std::string::npos ? std::string::npos : end - begin));
    if (end == std::string::npos) return parts;
    begin = end + 1;
  }
}

std::vector<std::string> whitespace_tokens(const std::string& text) {
  std::vector<std::string> tokens;
  std::istringstream in(text);
  std::string token;
  while (in >> token) tokens.push_back(token);
  return tokens;
}

// ---- a small XML parser (elements, attributes, character data, comments, the prolog) --------------

struct XmlElement {
  std::string name;
  std::vector<std::pair<std::string, std::string>> attributes;  // in document order, entities decoded
  std::vector<XmlElement> children;
  std::string text;  // character data directly inside, entities decoded

  bool has_attribute(const std::string& key) const {
    return std::any_of(attributes.begin(), attributes.end(), [&](const auto& a) { return a.first == key; });
  }
  const std::string& attribute(const std::string& key) const {
    for (const auto& a : attributes) {
      if (a.first == key) return a.second;
    }
    throw std::runtime_error("<" + name + "> has no attribute " + key);
  }
  std::vector<const XmlElement*> children_named(const std::string& n) const {
    std::vector<const XmlElement*> found;
    for (const auto& c : children) {
      if (c.name == n) found.push_back(&c);
    }
    return found;
  }
  const XmlElement& child(const std::string& n) const {
    const auto found = children_named(n);
    if (found.size() != 1) {
      throw std::runtime_error("<" + name + "> has " + std::to_string(found.size()) + " <" + n + ">");
    }
    return *found.front();
  }
};

class XmlReader {
 public:
  explicit XmlReader(std::string text) : s_(std::move(text)) {}

  XmlElement parse_document() {
    skip_space();
    if (starts_with("<?xml")) skip_past("?>");
    skip_misc();
    XmlElement root = parse_element();
    skip_misc();
    if (p_ != s_.size()) fail("content after the root element");
    return root;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error("XML: " + what + " at offset " + std::to_string(p_));
  }
  bool starts_with(std::string_view t) const { return std::string_view(s_).substr(p_, t.size()) == t; }
  void expect(std::string_view t) {
    if (!starts_with(t)) fail("expected '" + std::string(t) + "'");
    p_ += t.size();
  }
  void skip_space() {
    while (p_ < s_.size() && (s_[p_] == ' ' || s_[p_] == '\n' || s_[p_] == '\t' || s_[p_] == '\r')) ++p_;
  }
  void skip_past(std::string_view t) {
    const std::size_t at = s_.find(t, p_);
    if (at == std::string::npos) fail("unterminated construct, missing '" + std::string(t) + "'");
    p_ = at + t.size();
  }
  void skip_misc() {
    for (;;) {
      skip_space();
      if (starts_with("<!--")) {
        skip_past("-->");
      } else if (starts_with("<?")) {
        skip_past("?>");
      } else {
        return;
      }
    }
  }
  std::string parse_name() {
    const std::size_t begin = p_;
    while (p_ < s_.size() && (std::isalnum(static_cast<unsigned char>(s_[p_])) || s_[p_] == '_' || s_[p_] == ':' ||
                              s_[p_] == '-' || s_[p_] == '.')) {
      ++p_;
    }
    if (p_ == begin) fail("expected a name");
    return s_.substr(begin, p_ - begin);
  }
  std::string decode(std::string_view raw) const {
    std::string out;
    for (std::size_t i = 0; i < raw.size();) {
      if (raw[i] == '<') fail("'<' in character data or attribute value");
      if (raw[i] != '&') {
        out += raw[i++];
        continue;
      }
      const std::size_t semi = raw.find(';', i);
      if (semi == std::string_view::npos) fail("unterminated entity");
      const std::string_view entity = raw.substr(i + 1, semi - i - 1);
      if (entity == "amp") {
        out += '&';
      } else if (entity == "lt") {
        out += '<';
      } else if (entity == "gt") {
        out += '>';
      } else if (entity == "quot") {
        out += '"';
      } else if (entity == "apos") {
        out += '\'';
      } else if (entity.size() > 1 && entity[0] == '#') {
        const bool hex = entity[1] == 'x';
        const long code = std::strtol(std::string(entity.substr(hex ? 2 : 1)).c_str(), nullptr, hex ? 16 : 10);
        if (code <= 0 || code > 0x7f) fail("only ASCII character references are supported");
        out += static_cast<char>(code);
      } else {
        fail("unknown entity &" + std::string(entity) + ";");
      }
      i = semi + 1;
    }
    return out;
  }
  XmlElement parse_element() {
    expect("<");
    XmlElement e;
    e.name = parse_name();
    for (;;) {
      skip_space();
      if (starts_with("/>")) {
        p_ += 2;
        return e;
      }
      if (starts_with(">")) {
        ++p_;
        break;
      }
      std::string key = parse_name();
      if (e.has_attribute(key)) fail("duplicate attribute " + key);
      skip_space();
      expect("=");
      skip_space();
      if (p_ >= s_.size() || (s_[p_] != '"' && s_[p_] != '\'')) fail("expected a quoted value");
      const char quote = s_[p_++];
      const std::size_t end = s_.find(quote, p_);
      if (end == std::string::npos) fail("unterminated attribute value");
      std::string value = decode(std::string_view(s_).substr(p_, end - p_));
      p_ = end + 1;
      e.attributes.emplace_back(std::move(key), std::move(value));
    }
    for (;;) {
      if (p_ >= s_.size()) fail("unterminated element <" + e.name + ">");
      if (starts_with("</")) {
        p_ += 2;
        if (parse_name() != e.name) fail("mismatched closing tag for <" + e.name + ">");
        skip_space();
        expect(">");
        return e;
      }
      if (starts_with("<!--")) {
        skip_past("-->");
      } else if (starts_with("<")) {
        e.children.push_back(parse_element());
      } else {
        const std::size_t end = s_.find('<', p_);
        if (end == std::string::npos) fail("unterminated element <" + e.name + ">");
        e.text += decode(std::string_view(s_).substr(p_, end - p_));
        p_ = end;
      }
    }
  }

  std::string s_;
  std::size_t p_ = 0;
};

XmlElement read_xml(const fs::path& path) { return XmlReader(read_text(path)).parse_document(); }

// ---- a small JSON parser -----------------------------------------------------------------------------

struct JsonValue {
  enum class Kind { null, boolean, number, string, array, object };
  Kind kind = Kind::null;
  bool boolean = false;
  std::string text;               // a number's literal text, or a string's decoded value
  std::vector<JsonValue> items;   // array elements
  std::vector<std::string> keys;  // object keys in order, beside `values`
  std::vector<JsonValue> values;

  const JsonValue& at(const std::string& key) const {
    for (std::size_t i = 0; i < keys.size(); ++i) {
      if (keys[i] == key) return values[i];
    }
    throw std::runtime_error("no key " + key);
  }
  double number() const { return parse_double(text); }
};

class JsonReader {
 public:
  explicit JsonReader(std::string text) : s_(std::move(text)) {}

  JsonValue parse_document() {
    JsonValue v = parse_value();
    skip_space();
    if (p_ != s_.size()) fail("content after the value");
    return v;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error("JSON: " + what + " at offset " + std::to_string(p_));
  }
  void skip_space() {
    while (p_ < s_.size() && (s_[p_] == ' ' || s_[p_] == '\n' || s_[p_] == '\t' || s_[p_] == '\r')) ++p_;
  }
  bool take(std::string_view t) {
    if (std::string_view(s_).substr(p_, t.size()) != t) return false;
    p_ += t.size();
    return true;
  }
  std::string parse_string() {
    if (!take("\"")) fail("expected a string");
    std::string out;
    for (;;) {
      if (p_ >= s_.size()) fail("unterminated string");
      const char c = s_[p_++];
      if (c == '"') return out;
      if (static_cast<unsigned char>(c) < 0x20) fail("raw control character in a string");
      if (c != '\\') {
        out += c;
        continue;
      }
      if (p_ >= s_.size()) fail("unterminated escape");
      const char e = s_[p_++];
      switch (e) {
        case '"': out += '"'; break;
        case '\\': out += '\\'; break;
        case '/': out += '/'; break;
        case 'b': out += '\b'; break;
        case 'f': out += '\f'; break;
        case 'n': out += '\n'; break;
        case 'r': out += '\r'; break;
        case 't': out += '\t'; break;
        case 'u': {
          if (p_ + 4 > s_.size()) fail("short \\u escape");
          const std::string hex = s_.substr(p_, 4);
          if (hex.find_first_not_of("0123456789abcdefABCDEF") != std::string::npos) fail("bad \\u escape");
          const long code = std::strtol(hex.c_str(), nullptr, 16);
          if (code >= 0x80) fail("only ASCII \\u escapes are expected here");
          out += static_cast<char>(code);
          p_ += 4;
          break;
        }
        default: fail("unknown escape");
      }
    }
  }
  JsonValue parse_value() {
    skip_space();
    JsonValue v;
    if (p_ >= s_.size()) fail("expected a value");
    if (take("null")) return v;
    if (take("true") || take("false")) {
      v.kind = JsonValue::Kind::boolean;
      v.boolean = s_[p_ - 1] == 'e' && s_[p_ - 2] == 'u';
      return v;
    }
    if (s_[p_] == '"') {
      v.kind = JsonValue::Kind::string;
      v.text = parse_string();
      return v;
    }
    if (take("[")) {
      v.kind = JsonValue::Kind::array;
      skip_space();
      if (take("]")) return v;
      for (;;) {
        v.items.push_back(parse_value());
        skip_space();
        if (take("]")) return v;
        if (!take(",")) fail("expected , or ]");
      }
    }
    if (take("{")) {
      v.kind = JsonValue::Kind::object;
      skip_space();
      if (take("}")) return v;
      for (;;) {
        skip_space();
        v.keys.push_back(parse_string());
        skip_space();
        if (!take(":")) fail("expected :");
        v.values.push_back(parse_value());
        skip_space();
        if (take("}")) return v;
        if (!take(",")) fail("expected , or }");
      }
    }
    // A number, by the JSON grammar: -?(0|[1-9][0-9]*)(\.[0-9]+)?([eE][+-]?[0-9]+)?
    const std::size_t begin = p_;
    const auto digits = [&] {
      const std::size_t from = p_;
      while (p_ < s_.size() && std::isdigit(static_cast<unsigned char>(s_[p_]))) ++p_;
      if (p_ == from) fail("expected digits");
    };
    take("-");
    if (!take("0")) digits();
    if (take(".")) digits();
    if (take("e") || take("E")) {
      if (!take("+")) take("-");
      digits();
    }
    v.kind = JsonValue::Kind::number;
    v.text = s_.substr(begin, p_ - begin);
    return v;
  }

  std::string s_;
  std::size_t p_ = 0;
};

JsonValue read_json(const std::string& text) { return JsonReader(text).parse_document(); }

// ---- a fresh folder per test ------------------------------------------------------------------------

class OutputFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("dem_output_test_" + std::to_string(::getpid()) + "_" + std::string(info->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Names of the files in the folder, sorted.
  std::vector<std::string> files() const {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir_)) names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }

  fs::path dir_;
};

// ---- atomic writes ----------------------------------------------------------------------------------

TEST_F(OutputFiles, AtomicWriteReplacesContentAndLeavesNoTemporary) {
  const fs::path path = dir_ / "summary.json";
  write_file_atomically(path, "first");
  EXPECT_EQ(read_text(path), "first");
  const std::string binary("second\n\0with a nul\n", 19);
  write_file_atomically(path, binary);
  EXPECT_EQ(read_text(path), binary);
  write_file_atomically(path, "");
  EXPECT_EQ(read_text(path), "");
  EXPECT_EQ(files(), std::vector<std::string>{"summary.json"});
}

TEST_F(OutputFiles, AtomicWriteFailureThrowsNamingThePathAndLeavesNoTemporary) {
  const fs::path missing = dir_ / "no_such_folder" / "a.txt";
  try {
    write_file_atomically(missing, "x");
    FAIL() << "expected an exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(missing.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("No such file"), std::string::npos) << e.what();
  }
  // Renaming over a non-empty folder fails: the folder stays and the temporary is removed.
  fs::create_directories(dir_ / "occupied");
  write_text(dir_ / "occupied" / "inside", "keep");
  EXPECT_THROW(write_file_atomically(dir_ / "occupied", "x"), std::runtime_error);
  EXPECT_EQ(read_text(dir_ / "occupied" / "inside"), "keep");
  EXPECT_EQ(files(), std::vector<std::string>{"occupied"});
}

// ---- series -----------------------------------------------------------------------------------------

TEST(SeriesColumns, MatchTheDesignList) {
  const std::vector<std::string> expected = {
      "time",          "kinetic_energy", "rotational_energy", "potential_energy", "elastic_energy",
      "dissipated_energy", "momentum_x",  "momentum_y",       "momentum_z",       "contacts",
      "wall_contacts", "sync_intervals", "accepted_steps",    "rejected_steps",   "forced_steps",
      "particle_steps", "force_evaluations", "pair_rebuilds",
    "round_redos", "finest_level", "coarsest_level"};
  EXPECT_EQ(series_columns(), expected);
  const std::vector<std::string> walls = {"time",     "floor_fx", "floor_fy", "floor_fz", "floor_tx",
                                          "floor_ty", "floor_tz", "drum_fx",  "drum_fy",  "drum_fz",
                                          "drum_tx",  "drum_ty",  "drum_tz"};
  EXPECT_EQ(wall_columns({"floor", "drum"}), walls);
  EXPECT_EQ(wall_columns({}), std::vector<std::string>{"time"});
}

// Reads a series file: the header's names and the rows parsed with strtod.
struct SeriesFile {
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;
};

SeriesFile read_series(const fs::path& path) {
  const std::string text = read_text(path);
  if (text.empty() || text.back() != '\n') throw std::runtime_error("series does not end with a newline");
  std::vector<std::string> lines = split(text.substr(0, text.size() - 1), '\n');
  SeriesFile file;
  file.header = split(lines.at(0), ',');
  for (std::size_t i = 1; i < lines.size(); ++i) {
    std::vector<double> row;
    for (const std::string& cell : split(lines[i], ',')) row.push_back(parse_double(cell));
    if (row.size() != file.header.size()) throw std::runtime_error("row of the wrong length: " + lines[i]);
    file.rows.push_back(row);
  }
  return file;
}

TEST_F(OutputFiles, SeriesRowsReadBackBitExactly) {
  const fs::path path = dir_ / "series.csv";
  const std::vector<std::string> columns = {"time", "a", "b", "c", "d"};
  std::vector<std::vector<double>> rows = {
      {0.0, 0.1, 1.0 / 3.0, -0.0, std::numbers::pi},
      {0.1, 5e-324, std::numeric_limits<double>::max(), -std::numeric_limits<double>::min(), 9007199254740993.0},
      {0.2, 1e15, 123456789.0, -2.5e-300, 0.30000000000000004},
      {0.30000000000000004, kInf, -kInf, kNaN, 1e308},
  };
  std::mt19937_64 bits(12345);
  for (int r = 0; r < 20; ++r) {
    std::vector<double> row{0.4 + r};
    while (row.size() < columns.size()) {
      const double v = std::bit_cast<double>(bits());
      if (std::isfinite(v)) row.push_back(v);
    }
    rows.push_back(row);
  }
  {
    SeriesWriter writer(path, columns);
    for (const auto& row : rows) writer.append(row);
  }
  const SeriesFile file = read_series(path);
  EXPECT_EQ(file.header, columns);
  ASSERT_EQ(file.rows.size(), rows.size());
  for (std::size_t r = 0; r < rows.size(); ++r) {
    for (std::size_t c = 0; c < columns.size(); ++c) {
      if (std::isnan(rows[r][c])) {
        EXPECT_TRUE(std::isnan(file.rows[r][c])) << "row " << r << " column " << c;
      } else {
        EXPECT_TRUE(same_bits(file.rows[r][c], rows[r][c]))
            << "row " << r << " column " << c << ": " << file.rows[r][c] << " vs " << rows[r][c];
      }
    }
  }
  EXPECT_EQ(files(), std::vector<std::string>{"series.csv"});
}

TEST_F(OutputFiles, SeriesHeaderIsWrittenOnceAndResumeAppends) {
  const fs::path path = dir_ / "series.csv";
  {
    SeriesWriter writer(path, series_columns());
    EXPECT_EQ(read_text(path), split(read_text(path), '\n').at(0) + "\n") << "header written at creation";
    writer.append(std::vector<double>(series_columns().size(), 1.0));
    writer.append(std::vector<double>(series_columns().size(), 2.0));
  }
  {
    SeriesWriter writer(path, series_columns());
    writer.append(std::vector<double>(series_columns().size(), 3.0));
  }
  const SeriesFile file = read_series(path);
  EXPECT_EQ(file.header, series_columns());
  ASSERT_EQ(file.rows.size(), 3u);
  for (std::size_t r = 0; r < 3; ++r) EXPECT_EQ(file.rows[r][0], static_cast<double>(r + 1));
  const std::string text = read_text(path);
  std::size_t headers = 0;
  for (std::size_t at = 0; (at = text.find("time,", at)) != std::string::npos; ++at) ++headers;
  EXPECT_EQ(headers, 1u);
}

TEST_F(OutputFiles, SeriesWithADifferentHeaderThrows) {
  const fs::path path = dir_ / "walls.csv";
  {
    SeriesWriter writer(path, wall_columns({"floor"}));
    writer.append({0, 1, 2, 3, 4, 5, 6});
  }
  const std::string before = read_text(path);
  EXPECT_THROW(SeriesWriter(path, wall_columns({"drum"})), std::runtime_error);
  EXPECT_THROW(SeriesWriter(path, wall_columns({"floor", "drum"})), std::runtime_error);
  EXPECT_EQ(read_text(path), before);
  EXPECT_THROW(SeriesWriter(dir_ / "bad.csv", {"time", "a,b"}), std::invalid_argument);
  EXPECT_THROW(SeriesWriter(dir_ / "bad.csv", {}), std::invalid_argument);
}

TEST_F(OutputFiles, SeriesRejectsARowOfTheWrongLength) {
  SeriesWriter writer(dir_ / "series.csv", {"time", "a"});
  EXPECT_THROW(writer.append({1.0}), std::invalid_argument);
  EXPECT_THROW(writer.append({1.0, 2.0, 3.0}), std::invalid_argument);
  EXPECT_TRUE(read_series(dir_ / "series.csv").rows.empty());
}

TEST_F(OutputFiles, SeriesTruncateAfterKeepsRowsUpToTheTimeAndKeepsAppending) {
  const fs::path path = dir_ / "series.csv";
  const std::vector<double> times = {0.0, 0.1, 0.2, 0.30000000000000004, 0.4};
  SeriesWriter writer(path, {"time", "value"});
  for (std::size_t i = 0; i < times.size(); ++i) writer.append({times[i], static_cast<double>(i)});
  writer.truncate_after(0.2);  // a row exactly at the checkpoint's time stays
  SeriesFile file = read_series(path);
  ASSERT_EQ(file.rows.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) EXPECT_TRUE(same_bits(file.rows[i][0], times[i]));
  // The writer appends to the new file, not to the one the rename replaced.
  writer.append({0.25, 7.0});
  file = read_series(path);
  ASSERT_EQ(file.rows.size(), 4u);
  EXPECT_EQ(file.rows[3][0], 0.25);
  EXPECT_EQ(file.rows[3][1], 7.0);
  writer.truncate_after(-1.0);
  EXPECT_TRUE(read_series(path).rows.empty());
  EXPECT_EQ(read_series(path).header, (std::vector<std::string>{"time", "value"}));
  EXPECT_EQ(files(), std::vector<std::string>{"series.csv"});
}

TEST_F(OutputFiles, SeriesDropsARowTornByACrashWhenReopened) {
  const fs::path path = dir_ / "series.csv";
  write_text(path, "time,value\n0,1\n0.1,2");
  {
    SeriesWriter writer(path, {"time", "value"});
    writer.append({0.5, 3});
  }
  EXPECT_EQ(read_text(path), "time,value\n0,1\n0.5,3\n");
  write_text(path, "time,va");  // a torn header of the same columns
  {
    SeriesWriter writer(path, {"time", "value"});
    writer.append({0, 1});
  }
  EXPECT_EQ(read_text(path), "time,value\n0,1\n");
}

TEST_F(OutputFiles, SeriesWriterCanBeMoved) {
  const fs::path path = dir_ / "series.csv";
  SeriesWriter first(path, {"time"});
  SeriesWriter second(std::move(first));
  second.append({1.5});
  SeriesWriter third(dir_ / "other.csv", {"time"});
  third = std::move(second);
  third.append({2.5});
  const SeriesFile file = read_series(path);
  ASSERT_EQ(file.rows.size(), 2u);
  EXPECT_EQ(file.rows[1][0], 2.5);
}

// ---- JSON -------------------------------------------------------------------------------------------

TEST(Json, EscapesQuotesBackslashesAndControlCharacters) {
  EXPECT_EQ(json_escape("plain text"), "plain text");
  EXPECT_EQ(json_escape("a\"b\\c/d"), "a\\\"b\\\\c/d");
  EXPECT_EQ(json_escape("\n\r\t\b\f"), "\\n\\r\\t\\b\\f");
  EXPECT_EQ(json_escape(std::string("\x01\x1f\x00", 3)), "\\u0001\\u001f\\u0000");
  EXPECT_EQ(json_escape("\xc3\xa9\x7f"), "\xc3\xa9\x7f");  // UTF-8 and DEL pass through
}

JsonObject sample_object() {
  JsonObject inner;
  inner.add("depth", 2).add("empty", JsonObject{});
  JsonObject settings;
  settings.add("method", "verlet").add("dt", 1e-5).add("nested", inner);
  JsonObject root;
  root.add("version", std::string("0.1.0"))
      .add("threads", 2)
      .add("particles", std::size_t{1000})
      .add("min_int", std::numeric_limits<std::int64_t>::min())
      .add("max_uint", std::numeric_limits<std::uint64_t>::max())
      .add("ok", true)
      .add("failed", false)
      .add("third", 1.0 / 3.0)
      .add("negative_zero", -0.0)
      .add("not_a_number", kNaN)
      .add("infinite", -kInf)
      .add("settings", settings)
      .add("energy", std::vector<double>{0.1, kInf, kNaN, -2.5e-300})
      .add("no_values", std::vector<double>{})
      .add("text \"quoted\"", "line\nbreak \\ tab\t bell\x07 quote\"");
  return root;
}

void check_sample(const JsonValue& v) {
  using Kind = JsonValue::Kind;
  ASSERT_EQ(v.kind, Kind::object);
  const std::vector<std::string> keys = {"version", "threads",      "particles", "min_int",    "max_uint",
                                         "ok",      "failed",       "third",     "negative_zero",
                                         "not_a_number", "infinite", "settings", "energy",      "no_values",
                                         "text \"quoted\""};
  EXPECT_EQ(v.keys, keys);
  EXPECT_EQ(v.at("version").text, "0.1.0");
  EXPECT_EQ(v.at("threads").text, "2");
  EXPECT_EQ(v.at("particles").text, "1000");
  EXPECT_EQ(v.at("min_int").text, "-9223372036854775808");
  EXPECT_EQ(v.at("max_uint").text, "18446744073709551615");
  EXPECT_EQ(v.at("ok").kind, Kind::boolean);
  EXPECT_TRUE(v.at("ok").boolean);
  EXPECT_EQ(v.at("failed").kind, Kind::boolean);
  EXPECT_FALSE(v.at("failed").boolean);
  EXPECT_TRUE(same_bits(v.at("third").number(), 1.0 / 3.0));
  EXPECT_TRUE(same_bits(v.at("negative_zero").number(), -0.0));
  EXPECT_EQ(v.at("not_a_number").kind, Kind::null);
  EXPECT_EQ(v.at("infinite").kind, Kind::null);
  const JsonValue& settings = v.at("settings");
  ASSERT_EQ(settings.kind, Kind::object);
  EXPECT_EQ(settings.keys, (std::vector<std::string>{"method", "dt", "nested"}));
  EXPECT_EQ(settings.at("method").text, "verlet");
  EXPECT_TRUE(same_bits(settings.at("dt").number(), 1e-5));
  const JsonValue& nested = settings.at("nested");
  EXPECT_EQ(nested.keys, (std::vector<std::string>{"depth", "empty"}));
  EXPECT_EQ(nested.at("depth").text, "2");
  EXPECT_EQ(nested.at("empty").kind, Kind::object);
  EXPECT_TRUE(nested.at("empty").keys.empty());
  const JsonValue& energy = v.at("energy");
  ASSERT_EQ(energy.kind, Kind::array);
  ASSERT_EQ(energy.items.size(), 4u);
  EXPECT_TRUE(same_bits(energy.items[0].number(), 0.1));
  EXPECT_EQ(energy.items[1].kind, Kind::null);
  EXPECT_EQ(energy.items[2].kind, Kind::null);
  EXPECT_TRUE(same_bits(energy.items[3].number(), -2.5e-300));
  EXPECT_EQ(v.at("no_values").kind, Kind::array);
  EXPECT_TRUE(v.at("no_values").items.empty());
  EXPECT_EQ(v.at("text \"quoted\"").text, "line\nbreak \\ tab\t bell\x07 quote\"");
}

TEST(Json, DumpParsesBackWithKeysInOrderNestingNullsAndEscapes) {
  const JsonObject root = sample_object();
  for (const int indent : {2, 4, 0, -1}) {
    SCOPED_TRACE("indent " + std::to_string(indent));
    const std::string text = root.dump(indent);
    JsonValue v;
    ASSERT_NO_THROW(v = read_json(text)) << text;
    check_sample(v);
    if (indent <= 0) {
      EXPECT_EQ(text.find('\n'), std::string::npos);
    }
  }
}

TEST(Json, DumpLayoutIsFixed) {
  JsonObject inner;
  inner.add("x", 1.5);
  JsonObject o;
  o.add("a", 1).add("b", std::vector<double>{0.5, kNaN}).add("c", JsonObject{}).add("d", inner);
  EXPECT_EQ(o.dump(0), R"({"a":1,"b":[0.5,null],"c":{},"d":{"x":1.5}})");
  EXPECT_EQ(o.dump(2), "{\n  \"a\": 1,\n  \"b\": [0.5, null],\n  \"c\": {},\n  \"d\": {\n    \"x\": 1.5\n  }\n}");
  EXPECT_EQ(JsonObject{}.dump(2), "{}");
}

TEST(Json, DuplicateKeyThrows) {
  JsonObject o;
  o.add("a", 1.0);
  EXPECT_THROW(o.add("a", 2.0), std::invalid_argument);
  EXPECT_EQ(o.size(), 1u);
}

// ---- VTK --------------------------------------------------------------------------------------------

// One DataArray as written: its attributes and its values as tokens.
struct DataArray {
  std::string type, name;
  int components = 1;
  std::vector<std::string> values;
};

DataArray read_array(const XmlElement& e) {
  EXPECT_EQ(e.name, "DataArray");
  DataArray a;
  a.type = e.attribute("type");
  a.name = e.attribute("Name");
  EXPECT_EQ(e.attribute("format"), "ascii");
  if (e.has_attribute("NumberOfComponents")) a.components = std::stoi(e.attribute("NumberOfComponents"));
  a.values = whitespace_tokens(e.text);
  return a;
}

void expect_doubles(const DataArray& a, const std::vector<double>& expected) {
  ASSERT_EQ(a.values.size(), expected.size()) << a.name;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_TRUE(same_bits(parse_double(a.values[i]), expected[i]))
        << a.name << "[" << i << "]: " << a.values[i] << " vs " << expected[i];
  }
}

template <typename Int>
void expect_integers(const DataArray& a, const std::vector<Int>& expected) {
  ASSERT_EQ(a.values.size(), expected.size()) << a.name;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    char* end = nullptr;
    const std::string& token = a.values[i];
    if constexpr (std::is_signed_v<Int>) {
      EXPECT_EQ(std::strtoll(token.c_str(), &end, 10), static_cast<long long>(expected[i]))
          << a.name << "[" << i << "]";
    } else {
      EXPECT_EQ(std::strtoull(token.c_str(), &end, 10), static_cast<unsigned long long>(expected[i]))
          << a.name << "[" << i << "]";
    }
    EXPECT_EQ(end, token.c_str() + token.size()) << token;
  }
}

std::vector<double> flatten(const std::vector<Eigen::Vector3d>& v) {
  std::vector<double> out;
  for (const Eigen::Vector3d& x : v) out.insert(out.end(), {x.x(), x.y(), x.z()});
  return out;
}

const XmlElement& piece_of(const XmlElement& root) {
  EXPECT_EQ(root.name, "VTKFile");
  EXPECT_EQ(root.attribute("type"), "PolyData");
  EXPECT_EQ(root.attribute("version"), "1.0");
  EXPECT_EQ(root.attribute("byte_order"), "LittleEndian");
  return root.child("PolyData").child("Piece");
}

ParticleSnapshot random_snapshot(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 bits(seed);
  const auto any_finite = [&bits] {
    for (;;) {
      const double v = std::bit_cast<double>(bits());
      if (std::isfinite(v)) return v;
    }
  };
  ParticleSnapshot s;
  for (std::size_t i = 0; i < n; ++i) {
    s.id.push_back(static_cast<std::uint32_t>(bits()));
    s.position.emplace_back(any_finite(), 0.1 * static_cast<double>(i), -0.0);
    s.velocity.emplace_back(any_finite(), any_finite(), 1.0 / 3.0);
    s.angular_velocity.emplace_back(any_finite(), 5e-324, -1e308);
    s.radius.push_back(std::ldexp(static_cast<double>(bits() >> 11), -53) + 1e-3);
    s.level.push_back(static_cast<std::int32_t>(bits() % 41) - 20);
    s.force.emplace_back(any_finite(), -2.5, any_finite());
    s.torque.emplace_back(1e-300, any_finite(), any_finite());
    s.material.push_back(static_cast<std::uint16_t>(bits()));
    s.coordination.push_back(static_cast<std::uint32_t>(bits() % 13));
  }
  s.id.front() = std::numeric_limits<std::uint32_t>::max();
  s.level.back() = std::numeric_limits<std::int32_t>::min();
  return s;
}

TEST_F(OutputFiles, ParticlesVtpReadsBackExactly) {
  const ParticleSnapshot s = random_snapshot(7, 99);
  const fs::path path = dir_ / "particles_000001.vtp";
  write_particles_vtp(path, s, VtkFormat::ascii);
  EXPECT_EQ(files(), std::vector<std::string>{"particles_000001.vtp"});
  XmlElement root;
  ASSERT_NO_THROW(root = read_xml(path));
  const XmlElement& piece = piece_of(root);
  EXPECT_EQ(piece.attribute("NumberOfPoints"), "7");
  EXPECT_EQ(piece.attribute("NumberOfVerts"), "7");
  EXPECT_EQ(piece.attribute("NumberOfPolys"), "0");

  const XmlElement& point_data = piece.child("PointData");
  std::vector<DataArray> arrays;
  for (const XmlElement& e : point_data.children) arrays.push_back(read_array(e));
  ASSERT_EQ(arrays.size(), 9u);
  const std::vector<std::string> names = {"id",    "radius", "velocity", "angular_velocity", "level",
                                          "force", "torque", "material", "coordination"};
  const std::vector<std::string> types = {"UInt32",  "Float64", "Float64", "Float64", "Int32",
                                          "Float64", "Float64", "UInt16",  "UInt32"};
  const std::vector<int> components = {1, 1, 3, 3, 1, 3, 3, 1, 1};
  for (std::size_t a = 0; a < arrays.size(); ++a) {
    EXPECT_EQ(arrays[a].name, names[a]);
    EXPECT_EQ(arrays[a].type, types[a]) << names[a];
    EXPECT_EQ(arrays[a].components, components[a]) << names[a];
  }
  expect_integers(arrays[0], s.id);
  expect_doubles(arrays[1], s.radius);
  expect_doubles(arrays[2], flatten(s.velocity));
  expect_doubles(arrays[3], flatten(s.angular_velocity));
  expect_integers(arrays[4], s.level);
  expect_doubles(arrays[5], flatten(s.force));
  expect_doubles(arrays[6], flatten(s.torque));
  expect_integers(arrays[7], s.material);
  expect_integers(arrays[8], s.coordination);

  const DataArray points = read_array(piece.child("Points").child("DataArray"));
  EXPECT_EQ(points.type, "Float64");
  EXPECT_EQ(points.components, 3);
  expect_doubles(points, flatten(s.position));

  const XmlElement& verts = piece.child("Verts");
  ASSERT_EQ(verts.children.size(), 2u);
  const DataArray connectivity = read_array(verts.children[0]);
  const DataArray offsets = read_array(verts.children[1]);
  EXPECT_EQ(connectivity.name, "connectivity");
  EXPECT_EQ(offsets.name, "offsets");
  expect_integers(connectivity, std::vector<std::int64_t>{0, 1, 2, 3, 4, 5, 6});
  expect_integers(offsets, std::vector<std::int64_t>{1, 2, 3, 4, 5, 6, 7});
}

TEST_F(OutputFiles, ParticlesVtpWritesZerosForMissingSpinAndLevelAndHandlesNoParticles) {
  ParticleSnapshot s = random_snapshot(3, 7);
  s.angular_velocity.clear();
  s.level.clear();
  s.force.clear();
  s.torque.clear();
  s.material.clear();
  s.coordination.clear();
  const fs::path path = dir_ / "p.vtp";
  write_particles_vtp(path, s, VtkFormat::ascii);
  const XmlElement root = read_xml(path);
  const XmlElement& point_data = piece_of(root).child("PointData");
  ASSERT_EQ(point_data.children.size(), 9u);
  expect_doubles(read_array(point_data.children[3]), std::vector<double>(9, 0.0));
  expect_integers(read_array(point_data.children[4]), std::vector<std::int32_t>(3, 0));
  expect_doubles(read_array(point_data.children[5]), std::vector<double>(9, 0.0));
  expect_doubles(read_array(point_data.children[6]), std::vector<double>(9, 0.0));
  expect_integers(read_array(point_data.children[7]), std::vector<std::uint16_t>(3, 0));
  expect_integers(read_array(point_data.children[8]), std::vector<std::uint32_t>(3, 0));

  write_particles_vtp(path, ParticleSnapshot{}, VtkFormat::ascii);
  const XmlElement empty = read_xml(path);
  EXPECT_EQ(piece_of(empty).attribute("NumberOfPoints"), "0");
  for (const XmlElement& e : piece_of(empty).child("PointData").children) EXPECT_TRUE(read_array(e).values.empty());
}

TEST_F(OutputFiles, ParticlesVtpRejectsArraysOfDifferentSizes) {
  ParticleSnapshot s = random_snapshot(3, 1);
  s.radius.pop_back();
  EXPECT_THROW(write_particles_vtp(dir_ / "p.vtp", s), std::invalid_argument);
  s = random_snapshot(3, 1);
  s.level.push_back(0);
  EXPECT_THROW(write_particles_vtp(dir_ / "p.vtp", s), std::invalid_argument);
  s = random_snapshot(3, 1);
  s.coordination.pop_back();
  EXPECT_THROW(write_particles_vtp(dir_ / "p.vtp", s), std::invalid_argument);
  EXPECT_TRUE(files().empty());
}

TEST_F(OutputFiles, ParticlesVtpNamesTheMaterialsAsFieldData) {
  ParticleSnapshot s = random_snapshot(2, 5);
  s.material_names = {"steel", "a&b"};
  const fs::path path = dir_ / "p.vtp";
  write_particles_vtp(path, s, VtkFormat::ascii);
  const XmlElement root = read_xml(path);
  const XmlElement& names = root.child("PolyData").child("FieldData").child("DataArray");
  EXPECT_EQ(names.attribute("type"), "String");
  EXPECT_EQ(names.attribute("Name"), "material_names");
  EXPECT_EQ(names.attribute("NumberOfTuples"), "2");
  // Each string's bytes as numbers, then a 0.
  std::string decoded;
  for (const std::string& token : whitespace_tokens(names.text)) decoded += static_cast<char>(std::stoi(token));
  EXPECT_EQ(decoded, std::string("steel\0a&b\0", 10));
}

TEST_F(OutputFiles, ContactsVtpHasALinePerContactWithItsForces) {
  ContactSnapshot c;
  c.from = {{0, 0, 0}, {1, 2, 3}};
  c.to = {{0.5, 0, 0}, {1, 2, 2.5}};
  c.id_a = {3, 7};
  c.id_b = {9, -1};
  c.wall = {-1, 2};
  c.normal_force = {1.5, 1.0 / 3.0};
  c.normal_force_vector = {{-1.5, 0, 0}, {0, 0, 1.0 / 3.0}};
  c.tangential_force_vector = {{0, 0.25, 0}, {1e-300, 0, 0}};
  c.overlap = {1e-4, 2e-5};
  const fs::path path = dir_ / "contacts.vtp";
  write_contacts_vtp(path, c, VtkFormat::ascii);
  const XmlElement root = read_xml(path);
  const XmlElement& piece = piece_of(root);
  EXPECT_EQ(piece.attribute("NumberOfPoints"), "4");
  EXPECT_EQ(piece.attribute("NumberOfLines"), "2");
  EXPECT_EQ(piece.attribute("NumberOfVerts"), "0");
  std::vector<DataArray> arrays;
  for (const XmlElement& e : piece.child("CellData").children) arrays.push_back(read_array(e));
  ASSERT_EQ(arrays.size(), 7u);
  const std::vector<std::string> names = {"id_a", "id_b", "wall", "normal_force", "normal_force_vector",
                                          "tangential_force_vector", "overlap"};
  for (std::size_t a = 0; a < arrays.size(); ++a) EXPECT_EQ(arrays[a].name, names[a]);
  expect_integers(arrays[0], c.id_a);
  expect_integers(arrays[1], c.id_b);
  expect_integers(arrays[2], c.wall);
  expect_doubles(arrays[3], c.normal_force);
  expect_doubles(arrays[4], flatten(c.normal_force_vector));
  expect_doubles(arrays[5], flatten(c.tangential_force_vector));
  expect_doubles(arrays[6], c.overlap);
  expect_doubles(read_array(piece.child("Points").child("DataArray")),
                 flatten({c.from[0], c.to[0], c.from[1], c.to[1]}));
  const XmlElement& lines = piece.child("Lines");
  ASSERT_EQ(lines.children.size(), 2u);
  expect_integers(read_array(lines.children[0]), std::vector<std::int64_t>{0, 1, 2, 3});
  expect_integers(read_array(lines.children[1]), std::vector<std::int64_t>{2, 4});

  c.overlap.pop_back();
  EXPECT_THROW(write_contacts_vtp(path, c), std::invalid_argument);
}

Eigen::Matrix3d test_rotation() {
  return Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
}

WallGeometry three_walls() {
  WallGeometry g;
  append_wall_geometry(g, plane_geometry({0, 0, -1}, {0, 0, 1}, 2.0, 0));
  append_wall_geometry(g, box_geometry({1, 2, 3}, {0.5, 1.0, 1.5}, test_rotation(), 1));
  append_wall_geometry(g, cylinder_geometry({0, 0, 0}, {1, 1, 0}, 0.75, 3.0, 16, 2));
  return g;
}

TEST_F(OutputFiles, WallsVtpHasEveryTriangleWithValidIndicesAndItsWall) {
  const WallGeometry g = three_walls();
  ASSERT_EQ(g.triangles.size(), 2u + 12u + 32u);
  ASSERT_EQ(g.points.size(), 4u + 8u + 32u);
  const fs::path path = dir_ / "walls.vtp";
  write_walls_vtp(path, g, VtkFormat::ascii);
  const XmlElement root = read_xml(path);
  const XmlElement& piece = piece_of(root);
  const std::size_t point_count = std::stoul(piece.attribute("NumberOfPoints"));
  EXPECT_EQ(point_count, g.points.size());
  EXPECT_EQ(piece.attribute("NumberOfPolys"), "46");
  EXPECT_EQ(piece.attribute("NumberOfVerts"), "0");
  expect_doubles(read_array(piece.child("Points").child("DataArray")), flatten(g.points));

  const XmlElement& polys = piece.child("Polys");
  ASSERT_EQ(polys.children.size(), 2u);
  const DataArray connectivity = read_array(polys.children[0]);
  const DataArray offsets = read_array(polys.children[1]);
  EXPECT_EQ(connectivity.name, "connectivity");
  EXPECT_EQ(offsets.name, "offsets");
  ASSERT_EQ(connectivity.values.size(), 3 * g.triangles.size());
  ASSERT_EQ(offsets.values.size(), g.triangles.size());
  for (std::size_t t = 0; t < g.triangles.size(); ++t) {
    EXPECT_EQ(std::stoul(offsets.values[t]), 3 * (t + 1));
    for (std::size_t k = 0; k < 3; ++k) {
      const std::size_t index = std::stoul(connectivity.values[3 * t + k]);
      EXPECT_LT(index, point_count);
      EXPECT_EQ(index, g.triangles[t][k]);
    }
  }
  const DataArray wall = read_array(piece.child("CellData").child("DataArray"));
  EXPECT_EQ(wall.name, "wall");
  EXPECT_EQ(wall.type, "UInt32");
  std::vector<std::uint32_t> expected(2, 0);
  expected.resize(14, 1);
  expected.resize(46, 2);
  expect_integers(wall, expected);
}

TEST_F(OutputFiles, WallsVtpRejectsBadIndices) {
  WallGeometry g = plane_geometry({0, 0, 0}, {0, 1, 0}, 1.0);
  g.triangles[1][2] = 4;
  EXPECT_THROW(write_walls_vtp(dir_ / "walls.vtp", g), std::invalid_argument);
  g = plane_geometry({0, 0, 0}, {0, 1, 0}, 1.0);
  g.wall_index.pop_back();
  EXPECT_THROW(write_walls_vtp(dir_ / "walls.vtp", g), std::invalid_argument);
  EXPECT_TRUE(files().empty());
}

// ---- wall geometry ----------------------------------------------------------------------------------

Eigen::Vector3d area_vector(const WallGeometry& g, std::size_t t) {
  const auto& tri = g.triangles[t];
  return 0.5 * (g.points[tri[1]] - g.points[tri[0]]).cross(g.points[tri[2]] - g.points[tri[0]]);
}

Eigen::Vector3d centroid(const WallGeometry& g, std::size_t t) {
  const auto& tri = g.triangles[t];
  return (g.points[tri[0]] + g.points[tri[1]] + g.points[tri[2]]) / 3.0;
}

TEST(WallGeometryBuilders, PlaneIsASquareFacingTheNormal) {
  const Eigen::Vector3d point(1, -2, 0.5), normal(0.3, -1.0, 2.0);
  const WallGeometry g = plane_geometry(point, normal, 1.5, 4);
  ASSERT_EQ(g.triangles.size(), 2u);
  EXPECT_EQ(g.wall_index, (std::vector<std::uint32_t>{4, 4}));
  double area = 0;
  for (std::size_t t = 0; t < 2; ++t) {
    const Eigen::Vector3d a = area_vector(g, t);
    area += a.norm();
    EXPECT_NEAR(a.normalized().dot(normal.normalized()), 1.0, 1e-12);
  }
  EXPECT_NEAR(area, 9.0, 1e-12);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : g.points) {
    EXPECT_NEAR((p - point).dot(normal.normalized()), 0.0, 1e-12);
    EXPECT_NEAR((p - point).norm(), 1.5 * std::sqrt(2.0), 1e-12);
    mean += p / 4.0;
  }
  EXPECT_LT((mean - point).norm(), 1e-12);
}

TEST(WallGeometryBuilders, BoxHasTwelveOutwardTrianglesCoveringItsSurface) {
  const Eigen::Vector3d center(1, 2, 3), half(0.5, 1.0, 1.5);
  const Eigen::Matrix3d rotation = test_rotation();
  const WallGeometry g = box_geometry(center, half, rotation, 1);
  ASSERT_EQ(g.points.size(), 8u);
  ASSERT_EQ(g.triangles.size(), 12u);
  double area = 0;
  Eigen::Vector3d total = Eigen::Vector3d::Zero();  // a closed surface's area vectors sum to zero
  for (std::size_t t = 0; t < 12; ++t) {
    const Eigen::Vector3d a = area_vector(g, t);
    area += a.norm();
    total += a;
    EXPECT_GT(a.dot(centroid(g, t) - center), 0.0) << "triangle " << t << " faces inwards";
  }
  EXPECT_NEAR(area, 8 * (0.5 * 1.0 + 1.0 * 1.5 + 1.5 * 0.5), 1e-12);
  EXPECT_LT(total.norm(), 1e-12);
  for (const Eigen::Vector3d& p : g.points) {
    const Eigen::Vector3d local = rotation.transpose() * (p - center);
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(std::abs(local[a]), half[a], 1e-12);
  }
}

TEST(WallGeometryBuilders, CylinderSideFacesItsAxis) {
  const Eigen::Vector3d point(0.5, -1, 2), axis(0, 1, 1);
  const Eigen::Vector3d a = axis.normalized();
  const int segments = 24;
  const WallGeometry g = cylinder_geometry(point, axis, 0.75, 3.0, segments, 2);
  ASSERT_EQ(g.points.size(), 2u * segments);
  ASSERT_EQ(g.triangles.size(), 2u * segments);
  for (const Eigen::Vector3d& p : g.points) {
    const double along = (p - point).dot(a);
    EXPECT_NEAR(std::abs(along), 1.5, 1e-12);
    EXPECT_NEAR((p - point - along * a).norm(), 0.75, 1e-12);
  }
  double area = 0;
  for (std::size_t t = 0; t < g.triangles.size(); ++t) {
    const Eigen::Vector3d c = centroid(g, t);
    const Eigen::Vector3d radial = c - point - (c - point).dot(a) * a;
    const Eigen::Vector3d s = area_vector(g, t);
    area += s.norm();
    EXPECT_LT(s.dot(radial), 0.0) << "triangle " << t << " faces away from the axis";
  }
  // The prism inscribed in the cylinder: perimeter of the regular polygon times the length.
  EXPECT_NEAR(area, 2 * segments * 0.75 * std::sin(std::numbers::pi / segments) * 3.0, 1e-12);
}

TEST(WallGeometryBuilders, RejectDegenerateInput) {
  EXPECT_THROW(plane_geometry({0, 0, 0}, {0, 0, 0}, 1.0), std::invalid_argument);
  EXPECT_THROW(plane_geometry({0, 0, 0}, {0, 0, 1}, -1.0), std::invalid_argument);
  EXPECT_THROW(box_geometry({0, 0, 0}, {1, 0, 1}, Eigen::Matrix3d::Identity()), std::invalid_argument);
  EXPECT_THROW(box_geometry({0, 0, 0}, {1, 1, 1}, 2 * Eigen::Matrix3d::Identity()), std::invalid_argument);
  EXPECT_THROW(box_geometry({0, 0, 0}, {1, 1, 1}, -Eigen::Matrix3d::Identity()), std::invalid_argument);
  EXPECT_THROW(cylinder_geometry({0, 0, 0}, {0, 0, 1}, 1.0, kInf), std::invalid_argument);
  EXPECT_THROW(cylinder_geometry({0, 0, 0}, {0, 0, 1}, 1.0, 1.0, 2), std::invalid_argument);
  EXPECT_THROW(cylinder_geometry({0, 0, 0}, {0, 0, 0}, 1.0, 1.0), std::invalid_argument);
}

// ---- .pvd -------------------------------------------------------------------------------------------

struct PvdEntry {
  double time;
  std::string file;
};

std::vector<PvdEntry> read_pvd(const fs::path& path) {
  const XmlElement root = read_xml(path);
  EXPECT_EQ(root.name, "VTKFile");
  EXPECT_EQ(root.attribute("type"), "Collection");
  std::vector<PvdEntry> entries;
  const XmlElement& collection = root.child("Collection");
  EXPECT_EQ(collection.children.size(), collection.children_named("DataSet").size());
  for (const XmlElement* d : collection.children_named("DataSet")) {
    entries.push_back({parse_double(d->attribute("timestep")), d->attribute("file")});
  }
  return entries;
}

void expect_entries(const std::vector<PvdEntry>& got, const std::vector<PvdEntry>& expected) {
  ASSERT_EQ(got.size(), expected.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_TRUE(same_bits(got[i].time, expected[i].time)) << i << ": " << got[i].time;
    EXPECT_EQ(got[i].file, expected[i].file) << i;
  }
}

TEST_F(OutputFiles, PvdListsEachTimestepInOrderAfterEveryAdd) {
  const fs::path path = dir_ / "particles.pvd";
  const std::vector<PvdEntry> all = {{0.0, "particles_000000.vtp"},
                                     {0.1, "snapshots/particles_000001.vtp"},
                                     {0.30000000000000004, "a&b <\"quoted\"> 'it'.vtp"},
                                     {1e6, "late.vtp"}};
  PvdIndex index(path);
  EXPECT_FALSE(fs::exists(path));
  for (std::size_t i = 0; i < all.size(); ++i) {
    index.add(all[i].time, all[i].file);
    std::vector<PvdEntry> got;
    ASSERT_NO_THROW(got = read_pvd(path));
    expect_entries(got, std::vector<PvdEntry>(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(i) + 1));
  }
  EXPECT_THROW(index.add(1e6, "same_time.vtp"), std::invalid_argument);
  EXPECT_THROW(index.add(0.5, "earlier.vtp"), std::invalid_argument);
  EXPECT_THROW(index.add(kNaN, "nan.vtp"), std::invalid_argument);
  expect_entries(read_pvd(path), all);
  EXPECT_EQ(index.entries().size(), all.size());
  EXPECT_EQ(files(), std::vector<std::string>{"particles.pvd"});
}

TEST_F(OutputFiles, PvdReopenedKeepsItsEntriesAndTruncatesToTheCheckpoint) {
  const fs::path path = dir_ / "walls.pvd";
  {
    PvdIndex index(path);
    index.add(0.0, "w0.vtp");
    index.add(0.5, "w&1.vtp");
    index.add(1.0, "w2.vtp");
  }
  PvdIndex resumed(path);
  ASSERT_EQ(resumed.entries().size(), 3u);
  EXPECT_EQ(resumed.entries()[1].file, "w&1.vtp");
  resumed.truncate_after(0.5);
  expect_entries(read_pvd(path), {{0.0, "w0.vtp"}, {0.5, "w&1.vtp"}});
  resumed.add(0.75, "w3.vtp");
  expect_entries(read_pvd(path), {{0.0, "w0.vtp"}, {0.5, "w&1.vtp"}, {0.75, "w3.vtp"}});

  write_text(dir_ / "foreign.pvd", "not xml");
  EXPECT_THROW(PvdIndex(dir_ / "foreign.pvd"), std::runtime_error);
}

// ---- the test's own XML reader rejects what it should ----------------------------------------------

TEST(TestXmlReader, RejectsMalformedDocuments) {
  EXPECT_NO_THROW(XmlReader("<?xml version=\"1.0\"?>\n<a x=\"1\"><b/>text &amp; more</a>\n").parse_document());
  EXPECT_THROW(XmlReader("<a><b></a></b>").parse_document(), std::runtime_error);
  EXPECT_THROW(XmlReader("<a x=\"1\" x=\"2\"/>").parse_document(), std::runtime_error);
  EXPECT_THROW(XmlReader("<a>&bogus;</a>").parse_document(), std::runtime_error);
  EXPECT_THROW(XmlReader("<a>").parse_document(), std::runtime_error);
  EXPECT_THROW(XmlReader("<a/><b/>").parse_document(), std::runtime_error);
  EXPECT_THROW(read_json("{\"a\":1,}"), std::runtime_error);
  EXPECT_THROW(read_json("{\"a\":nan}"), std::runtime_error);
  EXPECT_THROW(read_json("[\"raw\ncontrol\"]"), std::runtime_error);
}

}  // namespace
}  // namespace dem
