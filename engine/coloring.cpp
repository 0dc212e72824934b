#include "engine/coloring.h"

#include <algorithm>
#include <bit>

namespace dem {

void color_contacts(std::size_t n, const std::vector<ParticleIndex>& i, const std::vector<ParticleIndex>& j,
                    ContactColoring& coloring) {
  const std::size_t m = i.size();
  auto& low_mask = coloring.low_mask;
  auto& high_used = coloring.high_used;
  low_mask.assign(n, 0);
  if (high_used.size() < n) high_used.resize(n);
  for (std::size_t p = 0; p < n; ++p) high_used[p].clear();
  coloring.color_of.resize(m);
  std::uint32_t colors = 0;
  for (std::size_t k = 0; k < m; ++k) {
    const ParticleIndex a = i[k], b = j[k];
    const std::uint64_t used = low_mask[a] | low_mask[b];
    std::uint32_t c;
    if (~used != 0) {
      c = static_cast<std::uint32_t>(std::countr_one(used));
      low_mask[a] |= std::uint64_t{1} << c;
      low_mask[b] |= std::uint64_t{1} << c;
    } else {
      c = 64;
      auto taken = [&](std::uint32_t x) {
        return std::find(high_used[a].begin(), high_used[a].end(), x) != high_used[a].end() ||
               std::find(high_used[b].begin(), high_used[b].end(), x) != high_used[b].end();
      };
      while (taken(c)) ++c;
      high_used[a].push_back(c);
      high_used[b].push_back(c);
    }
    coloring.color_of[k] = c;
    colors = std::max(colors, c + 1);
  }
  coloring.start.assign(colors + 1, 0);
  for (std::uint32_t c : coloring.color_of) ++coloring.start[c + 1];
  for (std::uint32_t c = 0; c < colors; ++c) coloring.start[c + 1] += coloring.start[c];
  coloring.contact.resize(m);
  auto& cursor = coloring.cursor;
  cursor.assign(coloring.start.begin(), coloring.start.end() - 1);
  for (std::size_t k = 0; k < m; ++k) coloring.contact[cursor[coloring.color_of[k]]++] = static_cast<std::uint32_t>(k);
}

}  // namespace dem
