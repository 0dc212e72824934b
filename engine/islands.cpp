#include "engine/islands.h"

namespace dem {
namespace {

std::uint32_t root(std::vector<std::uint32_t>& parent, std::uint32_t p) {
  while (parent[p] != p) {
    parent[p] = parent[parent[p]];  // path halving
    p = parent[p];
  }
  return p;
}

}  // namespace

void find_islands(std::size_t n, const PairContacts& contacts, Islands& islands) {
  find_islands(n, contacts.i, contacts.j, islands);
}

void find_islands(std::size_t n, std::span<const ParticleIndex> first, std::span<const ParticleIndex> second,
                  Islands& islands) {
  auto& parent = islands.parent;
  parent.resize(n);
  for (std::size_t p = 0; p < n; ++p) parent[p] = static_cast<std::uint32_t>(p);
  for (std::size_t k = 0; k < first.size(); ++k) {
    const std::uint32_t a = root(parent, first[k]), b = root(parent, second[k]);
    if (a < b) parent[b] = a;
    else if (b < a) parent[a] = b;
  }
  // Islands numbered by their smallest slot; members in ascending slot order (counting sort).
  islands.island_of.assign(n, 0);
  std::vector<std::uint32_t>& start = islands.start;
  start.clear();
  start.push_back(0);
  std::vector<std::uint32_t> number_of_root(n, 0);
  for (std::size_t p = 0; p < n; ++p) {
    const std::uint32_t r = root(parent, static_cast<std::uint32_t>(p));
    if (r == p) {
      number_of_root[p] = static_cast<std::uint32_t>(start.size() - 1);
      start.push_back(0);
    }
    islands.island_of[p] = number_of_root[r];
    ++start[islands.island_of[p] + 1];
  }
  for (std::size_t k = 1; k < start.size(); ++k) start[k] += start[k - 1];
  islands.member.resize(n);
  std::vector<std::uint32_t> cursor(start.begin(), start.end() - 1);
  for (std::size_t p = 0; p < n; ++p) islands.member[cursor[islands.island_of[p]]++] = static_cast<ParticleIndex>(p);
}

}  // namespace dem
