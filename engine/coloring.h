#pragma once
// Colouring of the contact graph: no two contacts of one colour share a particle, so the contacts of
// a colour can be processed in parallel while each particle is touched once (docs/physics.md 5.4, scheme
// D; 5, determinism). Greedy in ascending contact order (the sorted pair-key order), so the colours
// depend on the contact list only, never on threads. Uses at most 2 * max_degree - 1 colours.
// Serial: O(contacts x colours) with a 64-bit mask per particle for the first 64 colours.
#include <cstdint>
#include <vector>

#include "engine/contacts.h"

namespace dem {

struct ContactColoring {
  std::vector<std::uint32_t> color_of;  // per contact
  std::vector<std::uint32_t> start;     // size color_count + 1
  std::vector<std::uint32_t> contact;   // contacts of colour c: contact[start[c] .. start[c+1]), ascending
  // Scratch kept between calls (no allocation once warm): colours used at each particle.
  std::vector<std::uint64_t> low_mask;              // colours 0..63
  std::vector<std::vector<std::uint32_t>> high_used;  // colours >= 64 (rare: very high degree)
  std::vector<std::uint32_t> cursor;

  std::size_t color_count() const { return start.empty() ? 0 : start.size() - 1; }
};

/// Colours the contacts between `particle_count` particles given as (i, j) slot pairs.
void color_contacts(std::size_t particle_count, const std::vector<ParticleIndex>& i, const std::vector<ParticleIndex>& j,
                    ContactColoring& coloring);

}  // namespace dem
