// STL reading: both encodings, detection, scale, welding, and bad files rejected with clear messages.
#include "engine/stl_reader.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>

#include <Eigen/Geometry>

#include "engine/input_error.h"

namespace dem {
namespace {

namespace fs = std::filesystem;
using Triangle = std::array<Vec3, 3>;

/// Unit cube [0, s]^3 as 12 outward-facing triangles (counter-clockwise seen from outside).
std::vector<Triangle> cube_triangles(Real s = 1) {
  const Vec3 p[8] = {{0, 0, 0}, {s, 0, 0}, {s, s, 0}, {0, s, 0}, {0, 0, s}, {s, 0, s}, {s, s, s}, {0, s, s}};
  const int q[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {2, 3, 7, 6}, {1, 2, 6, 5}, {0, 4, 7, 3}};
  std::vector<Triangle> t;
  for (const auto& f : q) {
    t.push_back({p[f[0]], p[f[1]], p[f[2]]});
    t.push_back({p[f[0]], p[f[2]], p[f[3]]});
  }
  return t;
}

std::string ascii_stl(const std::vector<Triangle>& triangles, const std::string& name = "cube") {
  std::ostringstream s;
  s.precision(17);
  s << "solid " << name << "\n";
  for (const auto& t : triangles) {
    const Vec3 n = (t[1] - t[0]).cross(t[2] - t[0]).normalized();
    s << "  facet normal " << n.x() << ' ' << n.y() << ' ' << n.z() << "\n    outer loop\n";
    for (const Vec3& v : t) s << "      vertex " << v.x() << ' ' << v.y() << ' ' << v.z() << "\n";
    s << "    endloop\n  endfacet\n";
  }
  s << "endsolid " << name << "\n";
  return s.str();
}

void put_u32(std::string& out, std::uint32_t v) {
  for (int k = 0; k < 4; ++k) out.push_back(static_cast<char>((v >> (8 * k)) & 0xff));
}
void put_f32(std::string& out, float v) { put_u32(out, std::bit_cast<std::uint32_t>(v)); }

std::string binary_stl(const std::vector<Triangle>& triangles, const std::string& header = "binary cube") {
  std::string out(80, ' ');
  std::memcpy(out.data(), header.data(), std::min<std::size_t>(header.size(), 80));
  put_u32(out, static_cast<std::uint32_t>(triangles.size()));
  for (const auto& t : triangles) {
    for (int a = 0; a < 3; ++a) put_f32(out, 0.0f);  // normal: ignored
    for (const Vec3& v : t)
      for (int a = 0; a < 3; ++a) put_f32(out, static_cast<float>(v[a]));
    out.push_back(0), out.push_back(0);
  }
  return out;
}

class StlFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("dem_stl_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write(const std::string& name, const std::string& bytes) const {
    const fs::path path = dir_ / name;
    std::ofstream(path, std::ios::binary) << bytes;
    return path.string();
  }

  /// The message of the InputError that reading `path` throws (fails the test if none).
  static std::string error_of(const std::string& path, Real scale = 1, int* line = nullptr) {
    try {
      read_stl(path, scale);
    } catch (const InputError& e) {
      if (line) *line = e.line();
      return e.what();
    }
    ADD_FAILURE() << path << " was accepted";
    return {};
  }

  fs::path dir_;
};

TEST_F(StlFiles, AsciiAndBinaryOfOneCubeGiveIdenticalMeshes) {
  const StlMesh ascii = read_stl(write("a.stl", ascii_stl(cube_triangles())));
  const StlMesh binary = read_stl(write("b.stl", binary_stl(cube_triangles())));
  EXPECT_FALSE(ascii.binary);
  EXPECT_TRUE(binary.binary);
  ASSERT_EQ(ascii.vertices.size(), 8u);  // 36 corners welded into 8 vertices
  ASSERT_EQ(ascii.triangles.size(), 12u);
  EXPECT_EQ(ascii.vertices, binary.vertices);
  EXPECT_EQ(ascii.triangles, binary.triangles);
  EXPECT_EQ(ascii.degenerate_skipped, 0u);
  EXPECT_EQ(ascii.duplicate_skipped, 0u);
  // Corner order (the front side) is kept: the first triangle's normal points out of the cube (-z).
  const auto& t = ascii.triangles[0];
  const Vec3 n = (ascii.vertices[t[1]] - ascii.vertices[t[0]]).cross(ascii.vertices[t[2]] - ascii.vertices[t[0]]);
  EXPECT_LT(n.z(), 0);
}

TEST_F(StlFiles, BinaryWhoseHeaderStartsWithSolidIsReadAsBinary) {
  const StlMesh binary = read_stl(write("b.stl", binary_stl(cube_triangles(), "solid cube exported by a CAD tool")));
  EXPECT_TRUE(binary.binary);
  EXPECT_EQ(binary.triangles.size(), 12u);
  EXPECT_EQ(binary.vertices, read_stl(write("a.stl", ascii_stl(cube_triangles()))).vertices);
}

TEST_F(StlFiles, MillimetreScale) {
  const StlMesh mm = read_stl(write("mm.stl", binary_stl(cube_triangles(250))), 0.001);
  const StlMesh m = read_stl(write("m.stl", ascii_stl(cube_triangles(250))), 1);
  ASSERT_EQ(mm.vertices.size(), m.vertices.size());
  for (std::size_t v = 0; v < m.vertices.size(); ++v) EXPECT_EQ(mm.vertices[v], m.vertices[v] * 0.001);
  EXPECT_EQ(mm.vertices[6].maxCoeff(), 0.25);
}

TEST_F(StlFiles, KeywordsAnyCaseSeveralSolidsAndNoFinalNewline) {
  std::string text = ascii_stl(cube_triangles(), "first");
  std::string upper = ascii_stl({{Vec3(0, 0, 5), Vec3(1, 0, 5), Vec3(0, 1, 5)}}, "second");
  for (char& c : upper)
    if (c >= 'a' && c <= 'z') c = static_cast<char>(c - 'a' + 'A');
  upper.pop_back();
  const StlMesh mesh = read_stl(write("two.stl", text + upper));
  EXPECT_EQ(mesh.triangles.size(), 13u);
  EXPECT_EQ(mesh.vertices.size(), 11u);
}

TEST_F(StlFiles, WeldsIdenticalCoordinatesOnlyAndSignedZerosAlike) {
  const std::vector<Triangle> t = {{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)},
                                   {Vec3(-0.0, 1, 0), Vec3(1, 0, -0.0), Vec3(1, 1, 0)},
                                   {Vec3(1, 1, 0), Vec3(1 + 1e-12, 0, 0), Vec3(2, 1, 0)}};
  const StlMesh mesh = read_stl(write("w.stl", ascii_stl(t)));
  ASSERT_EQ(mesh.triangles.size(), 3u);
  EXPECT_EQ(mesh.vertices.size(), 6u);  // 1 + 1e-12 is a vertex of its own
  EXPECT_EQ(mesh.triangles[1][0], mesh.triangles[0][2]);
  EXPECT_EQ(mesh.triangles[1][1], mesh.triangles[0][1]);
}

TEST_F(StlFiles, DegenerateAndRepeatedTrianglesAreSkippedAndCounted) {
  std::vector<Triangle> t = cube_triangles();
  t.push_back({Vec3(0, 0, 0), Vec3(0, 0, 0), Vec3(1, 1, 1)});  // two corners alike
  t.push_back({Vec3(0, 0, 0), Vec3(1, 1, 1), Vec3(2, 2, 2)});  // collinear
  t.push_back({t[3][1], t[3][2], t[3][0]});                    // a repeat, rotated
  t.push_back({t[4][0], t[4][2], t[4][1]});                    // a repeat, flipped
  const StlMesh mesh = read_stl(write("d.stl", binary_stl(t)));
  EXPECT_EQ(mesh.triangles.size(), 12u);
  EXPECT_EQ(mesh.vertices.size(), 8u);  // (2, 2, 2) belonged to a skipped triangle only
  EXPECT_EQ(mesh.degenerate_skipped, 2u);
  EXPECT_EQ(mesh.duplicate_skipped, 2u);
}

TEST_F(StlFiles, TruncatedBinaryIsRejectedWithTheSizeRule) {
  std::string bytes = binary_stl(cube_triangles());
  bytes.resize(bytes.size() - 7);
  const std::string path = write("cut.stl", bytes);
  const std::string message = error_of(path);
  EXPECT_NE(message.find(path), std::string::npos) << message;
  EXPECT_NE(message.find("not an STL file"), std::string::npos) << message;
  EXPECT_NE(message.find("84 + 50 * 12 = 684 bytes"), std::string::npos) << message;
  EXPECT_NE(message.find("677"), std::string::npos) << message;
}

TEST_F(StlFiles, TruncatedBinaryBehindASolidHeaderSaysSo) {
  std::string bytes = binary_stl(cube_triangles(), "solid part");
  bytes.resize(bytes.size() - 50);
  const std::string message = error_of(write("cut.stl", bytes));
  EXPECT_NE(message.find("holds binary data"), std::string::npos) << message;
  EXPECT_NE(message.find("684 bytes"), std::string::npos) << message;
}

TEST_F(StlFiles, GarbageIsNotAnStl) {
  EXPECT_NE(error_of(write("short.stl", "hello")).find("not an STL file"), std::string::npos);
  const std::string message = error_of(write("png.stl", std::string("\x89PNG\r\n\x1a\n", 8) + std::string(200, 'x')));
  EXPECT_NE(message.find("not an STL file"), std::string::npos) << message;
  EXPECT_NE(message.find("'solid'"), std::string::npos) << message;
}

TEST_F(StlFiles, AsciiErrorsNameTheLineAndWhatWasExpected) {
  std::string text = ascii_stl(cube_triangles());
  const std::size_t at = text.find("endloop", text.find("endloop") + 1);  // second facet
  text.replace(at, 7, "endlop");
  int line = 0;
  const std::string message = error_of(write("typo.stl", text), 1, &line);
  EXPECT_EQ(line, 14);
  EXPECT_NE(message.find(":14:5:"), std::string::npos) << message;
  EXPECT_NE(message.find("expected 'endloop'"), std::string::npos) << message;
  EXPECT_NE(message.find("'endlop'"), std::string::npos) << message;

  const std::string cut = ascii_stl(cube_triangles()).substr(0, 200);
  const std::string cut_message = error_of(write("cut.stl", cut));
  EXPECT_NE(cut_message.find("the end of the file"), std::string::npos) << cut_message;

  std::string four = ascii_stl(cube_triangles());
  four.insert(four.find("endloop"), "      vertex 1 2 3\n");
  EXPECT_NE(error_of(write("four.stl", four), 1, &line).find("a facet has three vertices"), std::string::npos);
  EXPECT_EQ(line, 7);

  std::string word = ascii_stl(cube_triangles());
  word.replace(word.find("vertex 0 0 0") + 9, 1, "zero");
  EXPECT_NE(error_of(write("word.stl", word)).find("expected a number for a vertex coordinate, found 'zero'"),
            std::string::npos);
}

TEST_F(StlFiles, NonFiniteCoordinatesAreRejected) {
  std::string text = ascii_stl(cube_triangles());
  text.replace(text.find("vertex 0 0 0") + 9, 1, "nan");
  int line = 0;
  const std::string message = error_of(write("nan.stl", text), 1, &line);
  EXPECT_NE(message.find("not finite"), std::string::npos) << message;
  EXPECT_EQ(line, 4);

  std::vector<Triangle> t = cube_triangles();
  t[5][1].y() = std::numeric_limits<Real>::infinity();
  const std::string binary = error_of(write("inf.stl", binary_stl(t)));
  EXPECT_NE(binary.find("triangle 5"), std::string::npos) << binary;
  EXPECT_NE(binary.find("not finite"), std::string::npos) << binary;

  // A finite coordinate that overflows once scaled.
  const std::string scaled = error_of(write("big.stl", ascii_stl({{Vec3(0, 0, 0), Vec3(1e300, 0, 0), Vec3(0, 1, 0)}})), 1e10);
  EXPECT_NE(scaled.find("times the scale"), std::string::npos) << scaled;
}

TEST_F(StlFiles, NoTrianglesIsRejected) {
  EXPECT_NE(error_of(write("empty_binary.stl", binary_stl({}))).find("no triangles"), std::string::npos);
  EXPECT_NE(error_of(write("empty_ascii.stl", "solid nothing\nendsolid nothing\n")).find("no triangles"),
            std::string::npos);
  const std::string flat = error_of(write("flat.stl", ascii_stl({{Vec3(0, 0, 0), Vec3(1, 1, 1), Vec3(2, 2, 2)}})));
  EXPECT_NE(flat.find("degenerate"), std::string::npos) << flat;
}

TEST_F(StlFiles, MissingFileAndBadScale) {
  EXPECT_NE(error_of((dir_ / "absent.stl").string()).find("cannot open"), std::string::npos);
  const std::string path = write("a.stl", ascii_stl(cube_triangles()));
  EXPECT_NE(error_of(path, -1).find("positive"), std::string::npos);
  EXPECT_NE(error_of(path, 0).find("positive"), std::string::npos);
  EXPECT_NE(error_of(path, std::nan("")).find("positive"), std::string::npos);
}

}  // namespace
}  // namespace dem
