#pragma once
// Islands: connected components of the contact graph (docs/design.md, Time). Under step doubling an
// island steps at its finest member's level and retries as a whole; under the fixed control every
// particle steps together, so islands are only reported.
// Reads the pair contact list; writes the island of every particle and the members of each island.
// Serial union-find in contact order: the labels (smallest slot of the component) and the member
// order (ascending slot) do not depend on anything but the contact list.
#include <cstdint>
#include <span>
#include <vector>

#include "engine/contacts.h"

namespace dem {

struct Islands {
  std::vector<std::uint32_t> island_of;     // per particle: index into start/members lists
  std::vector<std::uint32_t> start;         // size island_count + 1
  std::vector<ParticleIndex> member;        // particles of island k are member[start[k] .. start[k+1])
  std::vector<std::uint32_t> parent;        // union-find scratch

  std::size_t count() const { return start.empty() ? 0 : start.size() - 1; }
};

/// Groups `particle_count` particles into islands joined by the contacts.
void find_islands(std::size_t particle_count, const PairContacts& contacts, Islands& islands);
/// The same for any links: particles first[k] and second[k] share an island.
void find_islands(std::size_t particle_count, std::span<const ParticleIndex> first,
                  std::span<const ParticleIndex> second, Islands& islands);

}  // namespace dem
