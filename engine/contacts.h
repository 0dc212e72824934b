#pragma once
// Contacts from candidate pairs and walls. Both lists are structures of arrays sorted by a 64-bit key
// (types.h: pair_key, wall_key); a new list inherits history (springs, modes) from the old one by
// key lookup, so history survives grid rebuilds unchanged. The law's constants are not stored: the
// force loops get them from the material table (MaterialTable::law_constants).
// Reads: positions, radii, masses (State), candidate pairs, walls. Writes: the contact lists and
// the per-particle adjacency used to gather forces.
// Threading: counts, scan and fills are per row (particle), each writing only its own range, so the
// lists are identical for any thread count.
#include <algorithm>
#include <cstdint>
#include <functional>
#include <vector>

#include "broadphase/candidate_pairs.h"
#include "engine/contact_law.h"
#include "engine/materials.h"
#include "engine/state.h"
#include "engine/wall_lists.h"
#include "engine/walls.h"

namespace dem {

/// Parts of a pair contact that only some runs use. A list stores only the parts its run needs
/// (docs/design.md, Models: what is not declared is not computed); a missing part reads as its start
/// value (zero springs, no books), which is all it would ever hold.
struct ContactParts {
  bool friction = true;  // tangential spring
  bool rolling = true;   // rolling spring and rolling torque
  bool books = true;     // the normal spring's energy books, for collision spectra
  bool keyed = true;     // key and i per contact (a persistent list knows i from its row, and no key)
};

/// The energy books of ContactHistory (docs/physics.md 7.4), stored apart: only collision spectra read them.
struct EnergyBooks {
  Real normal_work = 0;     // [J]
  Real normal_elastic = 0;  // [J]
  Real impact_energy = -1;  // [J]; negative until the first evaluation
};

/// Pair contacts as a structure of arrays; the history (ContactHistory) is split by part. A list is in
/// row order: by the slot of i, then by key; while slots follow ids (State::slots_follow_ids), that is
/// key order.
struct PairContacts {
  ContactParts parts;
  std::vector<std::uint64_t> key;   // pair_key(id_i, id_j)
  std::vector<ParticleIndex> i, j;  // slots, id_i < id_j
  std::vector<Vec3> tangential_spring;  // parts.friction [m]
  std::vector<Vec3> rolling_spring;     // parts.rolling [rad]
  std::vector<std::uint8_t> mode;       // ContactMode bits
  std::vector<EnergyBooks> books;       // parts.books
  std::vector<Real> overlap;        // at the last force evaluation [m]
  std::vector<Real> work;           // work done on the contact since it formed [J]
  std::vector<Real> elastic;        // energy in its springs at the last evaluation [J]
  std::vector<Vec3> force;          // on i; j gets the negative [N]
  // Torques are summed from these in the gather: on i -a_i n x force + rolling_torque, on j
  // -a_j n x force - rolling_torque, lever arms a = r - overlap / 2, the normal n recomputed there from
  // the positions exactly as the force loop computed it (no torque or moment vector per contact).
  std::vector<Vec3> rolling_torque;  // parts.rolling: on i [N m]
  // The contacts of row a (a = the slot of i, the pair's smaller id) are row_start[a] ..
  // row_start[a+1], ascending in key: history is inherited row by row.
  std::vector<std::uint32_t> row_start;

  std::size_t size() const { return j.size(); }  // j: the one index every list holds
  void resize(std::size_t n);
  /// Recomputes row_start from i and j (after a checkpoint is loaded).
  void index_rows(std::size_t particle_count);
  /// The history of contact k, missing parts at their start values.
  ContactHistory history(std::size_t k) const;
  void set_history(std::size_t k, const ContactHistory& h);

  /// Calls f(&PairContacts::field) for each per-contact array a list with these parts holds that a
  /// contact carries into the next list (history, books, overlap, work, elastic, force).
  template <class F>
  static void for_each_carried(const ContactParts& parts, F&& f) {
    if (parts.friction) f(&PairContacts::tangential_spring);
    if (parts.rolling) f(&PairContacts::rolling_spring);
    f(&PairContacts::mode);
    if (parts.books) f(&PairContacts::books);
    f(&PairContacts::overlap), f(&PairContacts::work), f(&PairContacts::elastic), f(&PairContacts::force);
  }
  /// The same for every per-contact array it holds (row_start is per row).
  template <class F>
  static void for_each_array(const ContactParts& parts, F&& f) {
    if (parts.keyed) f(&PairContacts::key), f(&PairContacts::i);
    f(&PairContacts::j);
    for_each_carried(parts, f);
    if (parts.rolling) f(&PairContacts::rolling_torque);
  }
};

/// True when the keys of `contacts` ascend along each of its rows (row_start), as row order asks.
bool keys_ascend_along_rows(const PairContacts& contacts);

/// Copies every field list `a` holds of contact `from` into slot `to` of `b` (which holds at least those).
void copy_pair(const PairContacts& a, std::size_t from, PairContacts& b, std::size_t to);

/// Wall contacts as a structure of arrays, ordered by particle slot, then by key (so key order while
/// slots follow ids): each particle's contacts are one range (ContactAdjacency::wall_start).
struct WallContacts {
  std::vector<std::uint64_t> key;  // wall_key(id, wall, feature)
  std::vector<ParticleIndex> particle;
  std::vector<std::uint32_t> wall;
  std::vector<std::uint32_t> feature;
  std::vector<ContactHistory> history;
  std::vector<Real> overlap;  // [m]
  std::vector<Real> work;     // work done on the contact since it formed [J]
  std::vector<Real> elastic;  // energy in its springs at the last evaluation [J]
  std::vector<Vec3> point;    // contact point [m]
  std::vector<Vec3> force;    // on the particle; the wall gets the negative [N]
  std::vector<Vec3> torque;   // on the particle [N m]
  std::vector<Vec3> rolling_torque;  // on the particle, the wall gets the negative [N m]

  std::size_t size() const { return key.size(); }
  void resize(std::size_t n);

  /// Calls f(&WallContacts::field) for each per-contact array (resize, copies, checkpoints, memory).
  template <class F>
  static void for_each_array(F&& f) {
    f(&WallContacts::key), f(&WallContacts::particle), f(&WallContacts::wall), f(&WallContacts::feature);
    f(&WallContacts::history), f(&WallContacts::overlap), f(&WallContacts::work), f(&WallContacts::elastic);
    f(&WallContacts::point), f(&WallContacts::force), f(&WallContacts::torque), f(&WallContacts::rolling_torque);
  }
};

/// True when `contacts` is ordered by particle slot, then by key, each key once per particle.
bool wall_keys_ascend_along_particles(const WallContacts& contacts);

/// Copies every field of wall contact `from` of `a` into slot `to` of `b`.
void copy_wall(const WallContacts& a, std::size_t from, WallContacts& b, std::size_t to);

/// The unit normal from j to i and the centres' distance, as every pair loop computes them: the
/// gather recomputes the force loop's normal from the same positions and relies on getting it bit
/// for bit. Coincident centres have no normal; any fixed choice keeps runs deterministic.
struct PairNormal {
  Vec3 n;
  Real distance;  // [m]
};
inline PairNormal pair_normal(const State& s, ParticleIndex i, ParticleIndex j) {
  const Vec3 d = s.position[i] - s.position[j];
  const Real dist = d.norm();
  return {dist > 0 ? Vec3(d / dist) : Vec3(Vec3::UnitX()), dist};
}

/// True when particles a and b overlap and so make a contact. Two immovable particles (inverse mass 0
/// both) have no finite effective mass: never a contact. Both tests are always made and joined
/// without a branch, so loops can sort candidates by it without one (neighbour_forces).
inline bool pair_touches(const State& s, ParticleIndex a, ParticleIndex b) {
  const Real reach = s.radius[a] + s.radius[b];
  const bool overlapping = (s.position[a] - s.position[b]).squaredNorm() < reach * reach;
  const bool movable = s.inv_mass[a] + s.inv_mass[b] > 0;  // inverse masses are never negative
  return overlapping & movable;
}

/// How deep a pair contact is, as the step watch reports it: its overlap over the smaller radius.
inline Real overlap_ratio(Real overlap, Real radius_a, Real radius_b) { return overlap / std::min(radius_a, radius_b); }

/// Books the step on which pair contact k (slots i, j: the force is on i) parted, from the positions
/// now, and returns what the contact dissipated over its life: its work minus what its springs held [J].
Real release_pair_contact(const State& state, const MaterialTable& materials, ParticleIndex i, ParticleIndex j,
                          PairContacts& contacts, std::size_t k);

/// Sets contact k's history, books, overlap and force to a new contact's start values.
void reset_pair_contact(PairContacts& contacts, std::size_t k);

/// Per-particle lists of contact slots for the gather, in ascending partner id order:
/// pair entries encode (contact << 1) | side, side 1 meaning the particle is j.
struct ContactAdjacency {
  std::vector<std::uint32_t> pair_start;  // size n + 1
  std::vector<std::uint32_t> pair_entry;
  std::vector<std::uint32_t> wall_start;  // size n + 1: wall contacts of particle p are a slot range
  std::vector<std::uint32_t> cursor;      // scratch of build_pair_adjacency
};

/// One touch of a particle with a wall feature, as update_wall_contacts' counting pass keeps it.
struct WallTouchFound {
  WallTouch touch;
  std::uint32_t wall;
  std::uint32_t feature;
};
/// How many touches per particle the counting pass keeps (most particles touch one wall feature).
inline constexpr std::uint32_t wall_touches_kept = 2;

/// Scratch buffers reused between calls (no allocation after warm-up).
struct ContactWorkspace {
  std::vector<std::uint32_t> count;
  std::vector<std::uint32_t> offset;
  std::vector<Real> row_ended;  // per row: what its ended contacts dissipated [J]
  // update_pair_contacts: the new list's keys (after the call, the old list's), and per new contact
  // its slot in the old list; the rest of a contact moves in place, through `carry`.
  std::vector<std::uint64_t> key;
  std::vector<std::uint32_t> source;
  PairContacts carry;  // the carried arrays only, one chunk long
  PairContacts pairs;  // step doubling's new list (world_doubling.cpp)
  WallContacts walls;
  // update_wall_contacts: per visited particle, the first wall_touches_kept touches its counting pass
  // found, so filling its row tests no wall again (a particle with more is tested again); and per
  // contact of the new list its geometry, which the force loop reads instead of testing again.
  std::vector<WallTouchFound> found;
  std::vector<WallTouch> wall_touch;
};

/// One contact that ended, for books kept per contact: its key (pair_key, or wall_key when `wall`)
/// and what it dissipated, its work less what its springs held [J].
struct EndedContact {
  std::uint64_t key = 0;
  bool wall = false;
  Real dissipated = 0;
};

/// Called by update_pair_contacts while the old list's keys and carried fields are still whole
/// (its i and j already hold the new list's), with the new list's keys.
using EndedPairsHook = std::function<void(const PairContacts& before, const std::vector<std::uint64_t>& after_key)>;

/// Replaces `contacts` by the overlapping candidate pairs, inheriting history by key, in place: only
/// the keys are built beside the old list (the old slots i, j are not needed: they are overwritten).
/// Slots must follow ids (the runs that use it never re-sort). Returns the energy dissipated by the
/// contacts that ended (their work minus what their springs held) [J]. The torques are left for the
/// force loop.
Real update_pair_contacts(const State& state, const broadphase::CandidatePairs& candidates,
                          const MaterialTable& materials, PairContacts& contacts, ContactWorkspace& work,
                          const EndedPairsHook& on_ended = {});

/// Replaces `contacts` by the current particle-wall overlaps, inheriting history by key, and leaves
/// each new contact's geometry in work.wall_touch for the force loop. Returns the energy dissipated by
/// the contacts that ended [J]. With `lists` (valid for this state, wall_lists.h) each particle is
/// tested against its listed walls only; without, against every wall: the same list. With `ended`,
/// appends each contact that ended, in the old list's order.
Real update_wall_contacts(const State& state, const Walls& walls, const MaterialTable& materials,
                          WallContacts& contacts, ContactWorkspace& work, std::vector<std::uint32_t>& wall_start,
                          const WallLists* lists = nullptr, std::vector<EndedContact>* ended = nullptr);

/// After State::permute(order), with new_of_old[order[q]] = q: the lists' slots renumbered and put in
/// the order a list of the new slots has (row order; by particle, then key), their history with
/// them; `scratch` is scratch.
void permute_particles(PairContacts& contacts, const std::vector<std::uint32_t>& new_of_old, PairContacts& scratch);
void permute_particles(WallContacts& contacts, const std::vector<std::uint32_t>& new_of_old, WallContacts& scratch);

/// The indices 0 .. n-1 of `keys` (unique) in ascending key order: how outputs and hashes walk a list,
/// whatever order the slots put it in.
std::vector<std::uint32_t> key_order(const std::vector<std::uint64_t>& keys);

/// Energy dissipated so far by the live contacts of a list: sum of work - elastic [J].
Real live_dissipation(const std::vector<Real>& work, const std::vector<Real>& elastic);

/// Builds the pair part of the gather adjacency (ascending partner id order per particle).
void build_pair_adjacency(std::size_t particle_count, const PairContacts& contacts, ContactAdjacency& adjacency);

}  // namespace dem
