// STL reading: format detection, the two encodings, then one welding and filtering pass shared by
// both (see stl_reader.h for the policy).
#include "engine/stl_reader.h"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>

#include <Eigen/Geometry>

#include "engine/input_error.h"

namespace dem {
namespace {

using Corners = std::array<Vec3, 3>;

constexpr std::size_t binary_header_bytes = 84;  // 80-byte header + uint32 triangle count
constexpr std::size_t binary_record_bytes = 50;  // normal, 3 vertices (12 float32), uint16 attribute

std::string str(std::uint64_t v) { return std::to_string(v); }

/// `bytes` quoted for a message: at most 24 characters, non-printable bytes as \xNN.
std::string quoted(std::string_view bytes) {
  std::ostringstream s;
  s << '\'';
  const std::size_t shown = std::min<std::size_t>(bytes.size(), 24);
  for (std::size_t k = 0; k < shown; ++k) {
    const auto c = static_cast<unsigned char>(bytes[k]);
    if (c >= 0x20 && c < 0x7f) {
      s << static_cast<char>(c);
    } else {
      static const char* hex = "0123456789abcdef";
      s << "\\x" << hex[c >> 4] << hex[c & 15];
    }
  }
  if (shown < bytes.size()) s << "...";
  s << '\'';
  return s.str();
}

bool equal_ignoring_case(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t k = 0; k < a.size(); ++k) {
    char c = a[k];
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    if (c != b[k]) return false;
  }
  return true;
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }

bool starts_with_solid(std::string_view bytes) {
  std::size_t k = 0;
  while (k < bytes.size() && is_space(bytes[k])) ++k;
  return bytes.size() - k >= 5 && equal_ignoring_case(bytes.substr(k, 5), "solid") &&
         (bytes.size() - k == 5 || is_space(bytes[k + 5]));
}

std::uint32_t read_u32(const char* p) {
  std::uint32_t v = 0;
  for (int k = 3; k >= 0; --k) v = (v << 8) | static_cast<unsigned char>(p[k]);
  return v;
}

float read_f32(const char* p) { return std::bit_cast<float>(read_u32(p)); }

/// Triangle count from a binary header, when the file's size is exactly 84 + 50 n for it.
bool binary_size_matches(std::string_view bytes, std::uint64_t& n) {
  if (bytes.size() < binary_header_bytes) return false;
  n = read_u32(bytes.data() + 80);
  return bytes.size() == binary_header_bytes + binary_record_bytes * n;
}

std::vector<Corners> read_binary(std::string_view bytes, const std::string& name, std::uint64_t n, Real scale) {
  std::vector<Corners> corners(n);
  for (std::uint64_t t = 0; t < n; ++t) {
    const char* record = bytes.data() + binary_header_bytes + binary_record_bytes * t;
    for (int v = 0; v < 3; ++v)
      for (int a = 0; a < 3; ++a) {
        const float raw = read_f32(record + 12 + 12 * v + 4 * a);
        const Real x = static_cast<Real>(raw) * scale;
        if (!std::isfinite(x)) {
          std::ostringstream s;
          s << "triangle " << t << " (record at byte " << (binary_header_bytes + binary_record_bytes * t)
            << "): vertex coordinate " << raw << (std::isfinite(raw) ? " times the scale" : "")
            << " is not finite; every coordinate must be a finite number";
          throw InputError(name, 0, 0, "", s.str());
        }
        corners[t][v][a] = x;
      }
  }
  return corners;
}

/// Tokens of an ASCII STL with their line and column, for messages.
class AsciiTokens {
 public:
  AsciiTokens(std::string_view bytes, const std::string& name) : bytes_(bytes), name_(name) {}

  /// Next token; empty at the end of the file.
  std::string_view next() {
    while (pos_ < bytes_.size() && is_space(bytes_[pos_])) advance();
    line_ = current_line_;
    column_ = static_cast<int>(pos_ - line_start_) + 1;
    const std::size_t begin = pos_;
    while (pos_ < bytes_.size() && !is_space(bytes_[pos_])) ++pos_;
    return bytes_.substr(begin, pos_ - begin);
  }

  /// Skips the rest of the current line (a solid's name).
  void skip_line() {
    while (pos_ < bytes_.size() && bytes_[pos_] != '\n') ++pos_;
  }

  void expect(std::string_view keyword, const char* context) {
    const std::string_view token = next();
    if (!equal_ignoring_case(token, keyword))
      fail("expected '" + std::string(keyword) + "' " + context + ", found " + found(token));
  }

  Real number(const char* what) {
    const std::string_view token = next();
    Real v = 0;
    const auto [end, err] = std::from_chars(token.data(), token.data() + token.size(), v);
    if (token.empty() || err != std::errc() || end != token.data() + token.size())
      fail(std::string("expected a number for ") + what + ", found " + found(token));
    return v;
  }

  static std::string found(std::string_view token) { return token.empty() ? "the end of the file" : quoted(token); }

  [[noreturn]] void fail(const std::string& message) const { throw InputError(name_, line_, column_, "", message); }

 private:
  void advance() {
    if (bytes_[pos_] == '\n') {
      ++current_line_;
      line_start_ = pos_ + 1;
    }
    ++pos_;
  }

  std::string_view bytes_;
  const std::string& name_;
  std::size_t pos_ = 0;
  std::size_t line_start_ = 0;
  int current_line_ = 1;
  int line_ = 1, column_ = 1;  // of the last token
};

std::vector<Corners> read_ascii(std::string_view bytes, const std::string& name, Real scale) {
  AsciiTokens in(bytes, name);
  std::vector<Corners> corners;
  in.expect("solid", "at the start of an ASCII STL");
  in.skip_line();
  for (;;) {
    const std::string_view token = in.next();
    if (equal_ignoring_case(token, "endsolid")) {
      in.skip_line();
      const std::string_view after = in.next();
      if (after.empty()) break;
      if (!equal_ignoring_case(after, "solid"))
        in.fail("expected another 'solid' or the end of the file after 'endsolid', found " + AsciiTokens::found(after));
      in.skip_line();
      continue;
    }
    if (!equal_ignoring_case(token, "facet"))
      in.fail("expected 'facet' or 'endsolid', found " + AsciiTokens::found(token));
    in.expect("normal", "after 'facet'");
    for (int a = 0; a < 3; ++a) in.number("the facet normal");  // ignored: the vertex order decides
    in.expect("outer", "after the facet normal");
    in.expect("loop", "after 'outer'");
    Corners c;
    for (int v = 0; v < 3; ++v) {
      in.expect("vertex", v == 0 ? "after 'outer loop'" : "(a facet has three vertices)");
      for (int a = 0; a < 3; ++a) {
        const Real raw = in.number("a vertex coordinate");
        c[v][a] = raw * scale;
        if (!std::isfinite(c[v][a])) {
          std::ostringstream s;
          s << "vertex coordinate " << raw << (std::isfinite(raw) ? " times the scale" : "")
            << " is not finite; every coordinate must be a finite number";
          in.fail(s.str());
        }
      }
    }
    in.expect("endloop", "after the third vertex (a facet has three vertices)");
    in.expect("endfacet", "after 'endloop'");
    corners.push_back(c);
  }
  return corners;
}

/// Welds corners with identical coordinates, drops degenerate and repeated triangles, numbers the
/// remaining vertices in order of first use.
StlMesh weld(std::vector<Corners> corners, const std::string& name) {
  StlMesh mesh;
  const std::size_t n = corners.size();
  std::vector<Vec3> point(3 * n);
  for (std::size_t t = 0; t < n; ++t)
    for (int v = 0; v < 3; ++v) point[3 * t + v] = corners[t][v] + Vec3::Zero();  // -0 + 0 = +0
  corners.clear();
  corners.shrink_to_fit();
  // Each corner's representative: the first corner with bitwise the same coordinates.
  std::vector<std::uint32_t> order(point.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = static_cast<std::uint32_t>(k);
  auto less = [&](std::uint32_t a, std::uint32_t b) {
    const Vec3& p = point[a];
    const Vec3& q = point[b];
    if (p.x() != q.x()) return p.x() < q.x();
    if (p.y() != q.y()) return p.y() < q.y();
    if (p.z() != q.z()) return p.z() < q.z();
    return a < b;
  };
  std::sort(order.begin(), order.end(), less);
  std::vector<std::uint32_t> representative(point.size());
  for (std::size_t k = 0; k < order.size();) {
    std::size_t end = k + 1;
    while (end < order.size() && point[order[end]] == point[order[k]]) ++end;
    for (std::size_t m = k; m < end; ++m) representative[order[m]] = order[k];  // order[k] is the smallest
    k = end;
  }
  // Degenerate triangles.
  std::vector<std::array<std::uint32_t, 3>> kept;
  kept.reserve(n);
  for (std::size_t t = 0; t < n; ++t) {
    const std::array<std::uint32_t, 3> c = {representative[3 * t], representative[3 * t + 1], representative[3 * t + 2]};
    const Vec3& a = point[c[0]];
    const Vec3& b = point[c[1]];
    const Vec3& d = point[c[2]];
    const Real longest = std::max({(b - a).squaredNorm(), (d - a).squaredNorm(), (d - b).squaredNorm()});
    const bool distinct = c[0] != c[1] && c[1] != c[2] && c[0] != c[2];
    if (!distinct || !((b - a).cross(d - a).norm() > 1e-12 * longest)) {
      ++mesh.degenerate_skipped;
      continue;
    }
    kept.push_back(c);
  }
  // Repeats: the same corner set as an earlier triangle, whatever the order.
  std::vector<std::pair<std::array<std::uint32_t, 3>, std::uint32_t>> sorted(kept.size());
  for (std::size_t t = 0; t < kept.size(); ++t) {
    std::array<std::uint32_t, 3> c = kept[t];
    std::sort(c.begin(), c.end());
    sorted[t] = {c, static_cast<std::uint32_t>(t)};
  }
  std::sort(sorted.begin(), sorted.end());
  std::vector<bool> repeat(kept.size(), false);
  for (std::size_t k = 1; k < sorted.size(); ++k)
    if (sorted[k].first == sorted[k - 1].first) repeat[sorted[k].second] = true;  // keeps the first of a run
  // Compact: vertices numbered in order of first use.
  std::vector<std::uint32_t> new_index(point.size(), UINT32_MAX);
  for (std::size_t t = 0; t < kept.size(); ++t) {
    if (repeat[t]) {
      ++mesh.duplicate_skipped;
      continue;
    }
    std::array<std::uint32_t, 3> tri;
    for (int v = 0; v < 3; ++v) {
      std::uint32_t& id = new_index[kept[t][v]];
      if (id == UINT32_MAX) {
        id = static_cast<std::uint32_t>(mesh.vertices.size());
        mesh.vertices.push_back(point[kept[t][v]]);
      }
      tri[v] = id;
    }
    mesh.triangles.push_back(tri);
  }
  if (mesh.triangles.empty()) {
    if (n == 0) throw InputError(name, 0, 0, "", "the STL file holds no triangles; a wall needs at least one");
    throw InputError(name, 0, 0, "", "all " + str(n) + " triangles of the STL file are degenerate (zero area) or "
                                     "repeated; a wall needs at least one proper triangle");
  }
  return mesh;
}

}  // namespace

StlMesh parse_stl(std::string_view bytes, const std::string& name, Real scale) {
  if (!(scale > 0) || !std::isfinite(scale))
    throw InputError(name, 0, 0, "", "the unit scale must be a positive finite number (0.001 for a file in mm)");
  std::uint64_t n = 0;
  if (binary_size_matches(bytes, n)) {
    StlMesh mesh = weld(read_binary(bytes, name, n, scale), name);
    mesh.binary = true;
    return mesh;
  }
  if (starts_with_solid(bytes)) {
    try {
      return weld(read_ascii(bytes, name, scale), name);
    } catch (const InputError& e) {
      if (bytes.size() < binary_header_bytes || std::memchr(bytes.data(), 0, bytes.size()) == nullptr) throw;
      // Binary bytes behind a "solid" header: most likely a binary STL cut short or padded.
      std::ostringstream s;
      s << e.what() << " (the file starts with 'solid' like an ASCII STL but holds binary data; as a binary STL, "
        << "its header's count of " << n << " triangles needs 84 + 50 * " << n << " = "
        << binary_header_bytes + binary_record_bytes * n << " bytes, and the file has " << bytes.size() << ")";
      throw InputError(name, 0, 0, "", s.str());
    }
  }
  std::ostringstream s;
  s << "not an STL file: ";
  if (bytes.size() < binary_header_bytes) {
    s << "it has " << bytes.size() << " bytes, fewer than a binary STL's 84-byte header, and does not start with "
      << "'solid' as an ASCII STL does";
  } else {
    s << "as a binary STL, its header's count of " << n << " triangles needs 84 + 50 * " << n << " = "
      << binary_header_bytes + binary_record_bytes * n << " bytes, but the file has " << bytes.size()
      << " (truncated, or not an STL); an ASCII STL would start with 'solid'";
  }
  throw InputError(name, 0, 0, "", s.str());
}

StlMesh read_stl(const std::string& path, Real scale) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, 0, "", "cannot open the STL file");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw InputError(path, 0, 0, "", "cannot read the STL file");
  return parse_stl(bytes, path, scale);
}

TriangleMesh read_stl_mesh(const std::string& path, Real scale) {
  StlMesh stl = read_stl(path, scale);
  return TriangleMesh(std::move(stl.vertices), std::move(stl.triangles));
}

}  // namespace dem
