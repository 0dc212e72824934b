#pragma once
// The persistent pair list of the fixed-step Verlet run: one slot per candidate pair, in CSR rows by
// the pair's smaller id (row a: the pairs (a, b) with id a < id b, by ascending id b, so keys ascend
// along each row; while slots follow ids, these are the broadphase's own rows), each slot
// carrying the pair's contact history while the pair touches and start values while it does not.
// Contact history thus lives with the candidate pair: between candidate rebuilds nothing is rebuilt,
// merged or moved; the force loop tests each slot for overlap and evaluates, starts or ends its
// contact in place (forces.h, neighbour forces). Only a candidate rebuild moves history, by a row-wise
// merge of keys from the compact contact list.
// The compact list (PairContacts of the touching pairs only, what outputs, checkpoints, islands and
// the embedding API read) is made from this one on demand by compact_touching, and this one is made
// anew from the compact list and new candidates by rebuild_neighbours.
// Every particle's contacts are summed in the order of its partners' ids, whatever the slots' order:
// particles re-sorted in memory move the same.
// Threading: every loop is per row (particle) or per slot, writing only its own slots; the serial
// passes run in slot order, so results are identical for any thread count.
#include <cstdint>
#include <vector>

#include "broadphase/candidate_pairs.h"
#include "engine/collision_spectra.h"
#include "engine/contacts.h"

namespace dem {

/// NeighbourContacts::row_deepest_slot of a row without a contact.
inline constexpr std::uint32_t no_deepest_slot = 0xffffffffu;

/// Values of NeighbourContacts::touching.
enum Touching : std::uint8_t { touching_no = 0, touching_yes = 1, touching_ended = 2 };

struct NeighbourContacts {
  // One slot per candidate pair: list.row_start and list.j are the candidates' rows and partners
  // by id; a slot's i is its row (the pair's smaller id) and it keeps no key (parts.keyed is false).
  PairContacts list;
  std::vector<std::uint8_t> touching;      // per slot: Touching
  std::vector<Vec3> moment;                // per slot, with rotation: n x force of the last evaluation, 0 if idle [N]
  // Per particle: its kind (particle_kinds.h), numbered by the last rebuild; a particle's material, mass,
  // inertia or radius never change between rebuilds (a change of the particles rebuilds the list).
  std::vector<std::uint32_t> kind;
  // For the gather: the slots in which particle p is j are reverse_slot[reverse_start[p] ..
  // reverse_start[p + 1]], by ascending id of their i; those in which it is i are its own row.
  std::vector<std::uint32_t> reverse_start;
  std::vector<std::uint32_t> reverse_slot;
  std::vector<Real> row_ended;             // per row: what its contacts that ended this step dissipated [J]
  std::vector<std::uint8_t> row_has_ended;  // per row: 1 when a contact of the row ended this step
  // Per row, from the last force loop: its deepest contact's overlap over the smaller radius, and
  // that contact's slot (no_deepest_slot when the row has none), for the step watch.
  std::vector<Real> row_deepest;
  std::vector<std::uint32_t> row_deepest_slot;
  // Contacts a rebuild left behind (no longer candidates: they parted by more than the skin, or the
  // skin is 0), as indices into the compact list it read, ascending; row a's are left_behind[
  // left_start[a] .. left_start[a + 1]]. They end with the contacts that part in the next force loop,
  // merged with them in key order, so sums and spectra are those of update_pair_contacts.
  std::vector<std::uint32_t> left_behind;
  std::vector<std::uint64_t> left_key;     // per left-behind contact: its key
  std::vector<Real> left_dissipated;       // per left-behind contact: its work less its springs' energy [J]
  std::vector<std::uint32_t> left_start;   // empty when nothing was left behind
  // Empty: the force loop visits every row. Else the only rows it visits, ascending: those holding
  // slots (a sparse list, such as one contact level's of a multilevel group), unless the last rebuild
  // left contacts behind. The others keep their reset values.
  std::vector<std::uint32_t> visited_rows;
  broadphase::CandidatePairs oriented;     // the candidates by id, when slots do not follow ids
  std::vector<std::uint8_t> inherited;     // scratch of rebuild_neighbours, per compact contact
  std::vector<std::uint32_t> cursor;       // scratch of rebuild_neighbours, per particle

  std::size_t size() const { return list.size(); }
};

/// Makes `neighbours` from the candidate pairs (a broadphase's, rows by the smaller slot), each slot
/// inheriting the history of the contact of `contacts` (compact, row order, row_start indexed) with
/// its key. Contacts that are no longer
/// candidates end without a release step, as update_pair_contacts ends them: they are listed in
/// left_behind for the next force loop and finish_ended_contacts, which read them from `contacts`
/// (it must stay unchanged until then).
void rebuild_neighbours(const State& state, const broadphase::CandidatePairs& candidates, const PairContacts& contacts,
                        NeighbourContacts& neighbours);

/// After the force loop: books the contacts that ended, those it marked touching_ended and those
/// the last rebuild left behind (read from `left_source`, the list rebuild_neighbours read), in key
/// order into `events` when given; resets the slots; returns what they dissipated [J], summed row by
/// row as update_pair_contacts sums the contacts that end. With `ended`, appends each of them in the
/// same order.
Real finish_ended_contacts(const State& state, NeighbourContacts& neighbours, const PairContacts& left_source,
                           ContactEvents* events, std::vector<EndedContact>* ended = nullptr);

/// Sets slot k to an idle pair's values: a new contact's history and books, no force, no torque.
void reset_neighbour(NeighbourContacts& neighbours, std::size_t k);

/// The candidates `by_slot` of a broadphase (rows by the smaller slot) in rows by the smaller id,
/// partners by ascending id, in `by_id`; `cursor` is scratch.
void orient_by_id(const State& state, const broadphase::CandidatePairs& by_slot, broadphase::CandidatePairs& by_id,
                  std::vector<std::uint32_t>& cursor);

/// The compact list of the touching slots, in row order, with row_start indexed.
void compact_touching(const State& state, const NeighbourContacts& neighbours, PairContacts& contacts,
                      std::vector<std::uint32_t>& scratch);

}  // namespace dem
