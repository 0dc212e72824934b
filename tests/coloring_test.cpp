// Contact colouring: a proper edge colouring (no particle twice in a colour), every contact exactly
// once, at most 2 * max_degree - 1 colours (greedy bound), identical on repeated calls.
#include <gtest/gtest.h>

#include <set>

#include "engine/coloring.h"
#include "tests/test_scenes.h"

namespace dem {
namespace {

void check(std::size_t n, const std::vector<ParticleIndex>& a, const std::vector<ParticleIndex>& b) {
  ContactColoring col;
  color_contacts(n, a, b, col);
  std::vector<std::size_t> degree(n, 0);
  for (std::size_t k = 0; k < a.size(); ++k) ++degree[a[k]], ++degree[b[k]];
  const std::size_t max_degree = a.empty() ? 0 : *std::max_element(degree.begin(), degree.end());
  EXPECT_LE(col.color_count(), max_degree == 0 ? 0 : 2 * max_degree - 1);
  std::vector<int> seen(a.size(), 0);
  for (std::size_t c = 0; c < col.color_count(); ++c) {
    std::set<ParticleIndex> touched;
    for (std::uint32_t e = col.start[c]; e < col.start[c + 1]; ++e) {
      const std::uint32_t k = col.contact[e];
      ++seen[k];
      EXPECT_EQ(col.color_of[k], c);
      EXPECT_TRUE(touched.insert(a[k]).second) << "particle twice in colour " << c;
      EXPECT_TRUE(touched.insert(b[k]).second) << "particle twice in colour " << c;
      if (e > col.start[c]) {
        EXPECT_LT(col.contact[e - 1], k);
      }
    }
  }
  for (int s : seen) EXPECT_EQ(s, 1);
  ContactColoring again;
  color_contacts(n, a, b, again);
  EXPECT_EQ(again.color_of, col.color_of);
}

TEST(Coloring, RandomGraphsAreProperlyColoured) {
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const std::size_t n = 300;
    std::set<std::pair<ParticleIndex, ParticleIndex>> edges;
    for (std::size_t k = 0; k < 900; ++k) {
      auto x = static_cast<ParticleIndex>(test::uniform(seed, 2 * k) * n);
      auto y = static_cast<ParticleIndex>(test::uniform(seed, 2 * k + 1) * n);
      if (x != y) edges.insert({std::min(x, y), std::max(x, y)});
    }
    std::vector<ParticleIndex> a, b;
    for (auto [x, y] : edges) a.push_back(x), b.push_back(y);
    check(n, a, b);
  }
}

TEST(Coloring, AStarBeyondSixtyFourColoursAndEmpty) {
  std::vector<ParticleIndex> a, b;
  for (ParticleIndex k = 1; k <= 150; ++k) a.push_back(0), b.push_back(k);  // one particle in 150 contacts
  for (ParticleIndex k = 1; k < 150; ++k) a.push_back(k), b.push_back(k + 1);
  check(151, a, b);
  check(5, {}, {});
}

}  // namespace
}  // namespace dem
