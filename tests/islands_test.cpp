// Islands are the connected components of the contact graph, checked against a breadth-first search.
#include <gtest/gtest.h>

#include <queue>

#include "engine/islands.h"
#include "tests/test_scenes.h"

namespace dem {
namespace {

PairContacts contacts_from(const std::vector<std::pair<ParticleIndex, ParticleIndex>>& edges) {
  PairContacts c;
  c.resize(edges.size());
  for (std::size_t k = 0; k < edges.size(); ++k) {
    c.i[k] = edges[k].first;
    c.j[k] = edges[k].second;
    c.key[k] = pair_key(edges[k].first, edges[k].second);
  }
  return c;
}

/// Component labels by breadth-first search, numbered in order of their smallest member.
std::vector<std::uint32_t> reference_labels(std::size_t n, const std::vector<std::pair<ParticleIndex, ParticleIndex>>& e) {
  std::vector<std::vector<std::uint32_t>> adj(n);
  for (auto [a, b] : e) adj[a].push_back(b), adj[b].push_back(a);
  std::vector<std::uint32_t> label(n, UINT32_MAX);
  std::uint32_t next = 0;
  for (std::size_t s = 0; s < n; ++s) {
    if (label[s] != UINT32_MAX) continue;
    std::queue<std::uint32_t> q;
    q.push(static_cast<std::uint32_t>(s));
    label[s] = next;
    while (!q.empty()) {
      const auto p = q.front();
      q.pop();
      for (auto o : adj[p])
        if (label[o] == UINT32_MAX) label[o] = next, q.push(o);
    }
    ++next;
  }
  return label;
}

TEST(Islands, MatchBreadthFirstComponentsOnRandomGraphs) {
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const std::size_t n = 200;
    std::vector<std::pair<ParticleIndex, ParticleIndex>> edges;
    for (std::size_t k = 0; k < 150; ++k) {
      auto a = static_cast<ParticleIndex>(test::uniform(seed, 2 * k) * n);
      auto b = static_cast<ParticleIndex>(test::uniform(seed, 2 * k + 1) * n);
      if (a == b) continue;
      edges.emplace_back(std::min(a, b), std::max(a, b));
    }
    Islands islands;
    find_islands(n, contacts_from(edges), islands);
    EXPECT_EQ(islands.island_of, reference_labels(n, edges));
    ASSERT_EQ(islands.member.size(), n);
    for (std::size_t k = 0; k < islands.count(); ++k)
      for (std::uint32_t m = islands.start[k]; m < islands.start[k + 1]; ++m) {
        EXPECT_EQ(islands.island_of[islands.member[m]], k);
        if (m > islands.start[k]) {
          EXPECT_LT(islands.member[m - 1], islands.member[m]);
        }
      }
  }
}

TEST(Islands, NoContactsMeansOneIslandPerParticle) {
  Islands islands;
  find_islands(5, PairContacts{}, islands);
  EXPECT_EQ(islands.count(), 5u);
}

}  // namespace
}  // namespace dem
