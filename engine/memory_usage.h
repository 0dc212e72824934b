#pragma once
// Heap bytes held by the engine's containers, counted by capacity (what is really allocated, not
// what is in use), for World::memory_breakdown. Counting helpers only: nothing here allocates.
#include <cstddef>
#include <string>
#include <vector>

#include "broadphase/candidate_pairs.h"
#include "engine/contacts.h"
#include "engine/neighbour_contacts.h"
#include "engine/state.h"

namespace dem {

/// One line of a memory breakdown: a container group and the heap bytes it holds.
struct MemoryPart {
  std::string name;
  std::size_t bytes = 0;
};

template <class T>
std::size_t heap_bytes(const std::vector<T>& v) {
  return v.capacity() * sizeof(T);
}

std::size_t heap_bytes(const State& s);
std::size_t heap_bytes(const PairContacts& c);
std::size_t heap_bytes(const WallContacts& c);
std::size_t heap_bytes(const ContactAdjacency& a);
std::size_t heap_bytes(const ContactWorkspace& w);
std::size_t heap_bytes(const broadphase::CandidatePairs& c);
std::size_t heap_bytes(const NeighbourContacts& nb);

}  // namespace dem
