#include "engine/checkpoint.h"

#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include "engine/atomic_file.h"
#include "engine/world.h"

namespace dem {
namespace {

struct Fnv1a {
  std::uint64_t value = 14695981039346656037ull;
  void add(const void* data, std::size_t bytes) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < bytes; ++i) {
      value ^= p[i];
      value *= 1099511628211ull;
    }
  }
  template <class T>
  void add(const T& v) {
    add(&v, sizeof(T));
  }
  void add_vec(const Vec3& v) { add(v.data(), 3 * sizeof(Real)); }
  void add_history(const ContactHistory& h) {
    add_vec(h.tangential_spring);
    add_vec(h.rolling_spring);
    add(h.mode);
  }
};

}  // namespace

std::uint64_t state_hash(const State& s, const PairContacts& pairs, const WallContacts& walls, const Clock& clock) {
  Fnv1a h;
  h.add(clock.interval);
  h.add(clock.tick);
  for (ParticleIndex p : s.index_of_id) {
    if (p == removed_slot) continue;  // removed by an embedding program
    h.add_vec(s.position[p]);
    h.add_vec(s.velocity[p]);
    h.add_vec(s.angular_velocity[p]);
  }
  // Contacts in key order, as particles in id order: the hash does not see the slots' order.
  for (std::uint32_t k : key_order(pairs.key)) {
    h.add(pairs.key[k]);
    h.add_history(pairs.history(k));
  }
  for (std::uint32_t k : key_order(walls.key)) {
    h.add(walls.key[k]);
    h.add_history(walls.history[k]);
  }
  return h.value;
}

}  // namespace dem

// ---- checkpoints ---------------------------------------------------------------------------------
// Layout: magic, format version, the scene's hashes, then every field below in order; vectors as a
// 64-bit count followed by their raw bytes (same binary on the same machine: checkpoints are for
// resuming, not for exchange), and a trailing FNV-1a of everything before it to catch truncation.

namespace dem {
namespace {

constexpr char checkpoint_magic[8] = {'D', 'E', 'M', 'C', 'K', 'P', 'T', '1'};
constexpr std::uint32_t checkpoint_version = 15;  // 8: pair contacts store only the parts their run uses; 9: exact pair histories hold their spring energy; 10: doubling runs book collision spectra; 11: spectra per kind of size classes; 12: the scene's body hash, method, time and clock origin, for a start under other integrator settings; 13: the energy given by set_velocity; 14: the interval of the last re-sort of the particles in memory; 15: the count of member retries

class ByteWriter {
 public:
  template <class T>
  void put(const T& v) {
    static_assert(std::is_arithmetic_v<T>);
    bytes_.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  template <class T>
  void put(const std::vector<T>& v) {
    put(static_cast<std::uint64_t>(v.size()));
    bytes_.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  std::string finish() {
    Fnv1a h;
    h.add(bytes_.data(), bytes_.size());
    put(h.value);
    return std::move(bytes_);
  }
  std::string& bytes() { return bytes_; }

 private:
  std::string bytes_;
};

class ByteReader {
 public:
  ByteReader(const std::string& bytes, const std::string& path) : bytes_(bytes), path_(path) {
    if (bytes_.size() < sizeof(std::uint64_t)) fail("file too short");
    Fnv1a h;
    h.add(bytes_.data(), bytes_.size() - sizeof(std::uint64_t));
    std::uint64_t stored = 0;
    std::memcpy(&stored, bytes_.data() + bytes_.size() - sizeof(stored), sizeof(stored));
    if (stored != h.value) fail("checksum mismatch (truncated or damaged file)");
    end_ = bytes_.size() - sizeof(std::uint64_t);
  }
  template <class T>
  T get() {
    T v;
    take(&v, sizeof(T));
    return v;
  }
  template <class T>
  void get(std::vector<T>& v) {
    const auto n = get<std::uint64_t>();
    if (n > (end_ - at_) / std::max<std::size_t>(sizeof(T), 1)) fail("vector length beyond the end of the file");
    v.resize(n);
    take(v.data(), n * sizeof(T));
  }
  void take(void* out, std::size_t n) {
    if (end_ - at_ < n) fail("unexpected end of file");
    if (n > 0) std::memcpy(out, bytes_.data() + at_, n);  // an empty vector's data() may be null
    at_ += n;
  }
  bool done() const { return at_ == end_; }
  [[noreturn]] void fail(const std::string& why) const {
    throw std::runtime_error("checkpoint '" + path_ + "': " + why);
  }

 private:
  const std::string& bytes_;
  std::string path_;
  std::size_t at_ = 0, end_ = 0;
};

// One list of the fields, used for both directions, so save and load cannot drift apart.
template <class Io, class T>  // T: PairContacts, const or not
void pair_fields(Io& io, T& c) {
  PairContacts::for_each_array(c.parts, [&](auto field) { io(c.*field); });
}
template <class Io, class T>  // T: WallContacts, const or not
void wall_fields(Io& io, T& c) {
  WallContacts::for_each_array([&](auto field) { io(c.*field); });
}
template <class Io, class T>  // T: State, const or not
void state_fields(Io& io, T& s) {
  io(s.id), io(s.position), io(s.velocity), io(s.angular_velocity), io(s.force), io(s.torque), io(s.radius),
      io(s.inv_mass), io(s.inv_inertia), io(s.material), io(s.level), io(s.index_of_id);
}

}  // namespace

/// A checkpoint as read and checked: everything World::take_checkpoint commits, and what only a
/// resume takes (clock, counters, origin).
struct CheckpointContents {
  CheckpointHeader header;
  Real origin = 0;  // [s] Scheduler::origin
  Clock clock;
  RunCounters counters;
  Real ended = 0, exact_dissipated = 0, candidate_skin = 0, wall_work = 0, given_energy = 0;
  std::int64_t sorted_at = -1;
  Energies start;
  State state;
  PairContacts pairs;
  WallContacts walls;
  broadphase::CandidatePairs candidates;
  std::vector<Vec3> reference;
  std::vector<ExactHistoryRecord> exact_history;
  bool has_spectra = false;
  CollisionSpectra::Books spectra_books;
};

namespace {

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open checkpoint '" + path + "'");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

CheckpointHeader read_header(ByteReader& r) {
  char magic[sizeof checkpoint_magic];
  r.take(magic, sizeof magic);
  if (std::memcmp(magic, checkpoint_magic, sizeof magic) != 0) r.fail("not a dem checkpoint");
  if (r.get<std::uint32_t>() != checkpoint_version) r.fail("written by another checkpoint format version");
  CheckpointHeader h;
  h.hashes.physics = r.get<std::uint64_t>();
  h.hashes.body = r.get<std::uint64_t>();
  const auto method = r.get<std::uint8_t>();
  if (method != static_cast<std::uint8_t>(Method::verlet) && method != static_cast<std::uint8_t>(Method::exact))
    r.fail("damaged header");
  h.method = static_cast<Method>(method);
  h.time = r.get<Real>();
  return h;
}

/// Reads and checks the file: format, checksum and the consistency of its lists, against a world
/// whose pair contacts keep `parts`, with `spectra` (null: none). `check_header` judges the hashes
/// and method (what must match depends on the use) before the rest is read, and throws to refuse.
template <class CheckHeader>
CheckpointContents read_checkpoint(const std::string& path, const ContactParts& parts, const CollisionSpectra* spectra,
                                   std::size_t particle_count, const CheckHeader& check_header) {
  const std::string bytes = file_bytes(path);
  ByteReader r(bytes, path);
  CheckpointContents c;
  c.header = read_header(r);
  check_header(c.header);
  c.origin = r.get<Real>();
  c.clock.interval = r.get<std::int64_t>();
  c.clock.tick = r.get<std::int64_t>();
  RunCounters& counters = c.counters;
  for (std::uint64_t* v : {&counters.sync_intervals, &counters.accepted_steps, &counters.rejected_steps,
                           &counters.forced_steps, &counters.particle_steps, &counters.force_evaluations,
                           &counters.pair_rebuilds, &counters.richardson_steps, &counters.round_redos,
                           &counters.unresolved_contacts, &counters.member_retries})
    *v = r.get<std::uint64_t>();
  r.get(counters.level_histogram);
  c.ended = r.get<Real>();
  c.exact_dissipated = r.get<Real>();
  c.candidate_skin = r.get<Real>();
  c.wall_work = r.get<Real>();
  c.given_energy = r.get<Real>();
  c.sorted_at = r.get<std::int64_t>();
  for (Real* e : {&c.start.kinetic, &c.start.rotational, &c.start.potential, &c.start.elastic}) *e = r.get<Real>();
  c.pairs.parts = parts;  // the scene's, as when saved
  auto io = [&](auto& v) { r.get(v); };
  state_fields(io, c.state);
  pair_fields(io, c.pairs);
  wall_fields(io, c.walls);
  r.get(c.candidates.row_start);
  r.get(c.candidates.partner);
  r.get(c.reference);
  r.get(c.exact_history);
  c.has_spectra = r.get<std::uint8_t>() != 0;
  if (c.has_spectra != (spectra != nullptr)) r.fail("collision spectra do not match the scene's");
  if (c.has_spectra) {
    if (r.get<std::uint32_t>() != static_cast<std::uint32_t>(spectra->kind_count()))
      r.fail("collision spectra have other size classes than the scene's");
    r.get(c.spectra_books.count);
    r.get(c.spectra_books.energy);
    r.get(c.spectra_books.events);
    c.spectra_books.dissipated = r.get<double>();
    if (!CollisionSpectra(spectra->edges()).set_books(c.spectra_books)) r.fail("damaged collision spectra");
  }
  if (!r.done()) r.fail("unexpected bytes after the last field");
  if (c.state.size() != particle_count) r.fail("particle count differs from the scene's");
  bool same_counts = true;
  PairContacts::for_each_array(c.pairs.parts, [&](auto field) {
    same_counts = same_counts && (c.pairs.*field).size() == c.pairs.size();
  });
  if (!same_counts) r.fail("damaged contact list");
  if (!broadphase::is_valid(c.candidates, c.state.size())) r.fail("damaged neighbour list");
  return c;
}

const char* method_name(Method method) { return method == Method::exact ? "exact" : "verlet"; }

}  // namespace

std::string start_refusal(const CheckpointHeader& header, const SceneHashes& hashes, Method method) {
  if (header.hashes.body != hashes.body)
    return "it belongs to a scene with other particles, materials, contacts, walls, mill or model; only "
           "[integrator], [broadphase], [run], [output] and [accuracy] may differ";
  if (header.method != method)
    return std::string("written by integrator.method = \"") + method_name(header.method) +
           "\", and a run starts from it with the same method (this one is \"" + method_name(method) + "\")";
  return "";
}

CheckpointHeader read_checkpoint_header(const std::string& path) {
  const std::string bytes = file_bytes(path);
  ByteReader r(bytes, path);
  return read_header(r);
}

void World::save_checkpoint(const std::string& path, const SceneHashes& hashes) const {
  write_file_atomically(path, checkpoint_bytes(hashes));
}

std::string World::checkpoint_bytes(const SceneHashes& hashes) const {
  ByteWriter w;
  w.bytes().append(checkpoint_magic, sizeof checkpoint_magic);
  w.put(checkpoint_version);
  w.put(hashes.physics);
  w.put(hashes.body);
  w.put(static_cast<std::uint8_t>(config_.integrator.method));  // as read_header reads it
  w.put(time());
  w.put(scheduler_.origin());
  w.put(clock_.interval);
  w.put(clock_.tick);
  for (std::uint64_t v : {counters_.sync_intervals, counters_.accepted_steps, counters_.rejected_steps,
                          counters_.forced_steps, counters_.particle_steps, counters_.force_evaluations,
                          counters_.pair_rebuilds, counters_.richardson_steps, counters_.round_redos,
                          counters_.unresolved_contacts, counters_.member_retries})
    w.put(v);
  w.put(counters_.level_histogram);
  w.put(ended_dissipation_);
  w.put(exact_dissipated_);
  w.put(candidate_skin_);
  w.put(wall_work_);
  w.put(given_energy_);
  w.put(sorted_at_);
  for (Real e : {start_energies_.kinetic, start_energies_.rotational, start_energies_.potential, start_energies_.elastic})
    w.put(e);
  auto io = [&](auto& v) { w.put(v); };
  state_fields(io, state_);
  pair_fields(io, pair_contacts());
  wall_fields(io, wall_contacts_);
  w.put(candidates_.row_start);
  w.put(candidates_.partner);
  const auto reference = skin_tracker_.reference();
  w.put(std::vector<Vec3>(reference.begin(), reference.end()));
  w.put(exact_work_.history);  // the exact stepper's wall-contact springs and modes
  // Spectra: a flag, then (when booked) their kind count, bin counts and energies, events per kind and total.
  w.put(static_cast<std::uint8_t>(spectra_ ? 1 : 0));
  if (spectra_) {
    const CollisionSpectra::Books books = spectra_->books();
    w.put(static_cast<std::uint32_t>(spectra_->kind_count()));
    w.put(books.count);
    w.put(books.energy);
    w.put(books.events);
    w.put(books.dissipated);
  }
  return w.finish();
}

void World::load_checkpoint(const std::string& path, const SceneHashes& hashes) {
  CheckpointContents c =
      read_checkpoint(path, pairs_.parts, spectra_.get(), state_.size(), [&](const CheckpointHeader& header) {
        if (header.hashes.physics == hashes.physics) return;
        const std::string hint = header.hashes.body == hashes.body
                                     ? "; only its integrator or broadphase settings differ: start from it with --from"
                                     : "";
        throw std::runtime_error("checkpoint '" + path +
                                 "': it belongs to a scene with different physics (the scene, or a --set of it, "
                                 "changed since)" + hint);
      });
  // Everything read and checked: commit.
  clock_ = c.clock;
  counters_ = std::move(c.counters);
  scheduler_.set_origin(c.origin);
  take_checkpoint(c);
}

void World::start_from_checkpoint(const std::string& path, const SceneHashes& hashes) {
  const Method method = config_.integrator.method;
  CheckpointContents c =
      read_checkpoint(path, pairs_.parts, spectra_.get(), state_.size(), [&](const CheckpointHeader& header) {
        if (const std::string why = start_refusal(header, hashes, method); !why.empty())
          throw std::runtime_error("checkpoint '" + path + "': " + why);
      });
  // Everything read and checked: commit. The clock reads zero at the checkpoint's time.
  clock_ = Clock{};
  counters_ = RunCounters{};
  scheduler_.set_origin(c.header.time);
  take_checkpoint(c);
  sorted_at_ = -1;  // a new run's
  for (auto& level : state_.level) level = static_cast<std::int8_t>(initial_level());
}

void World::take_checkpoint(CheckpointContents& c) {
  ended_dissipation_ = c.ended;
  exact_dissipated_ = c.exact_dissipated;
  candidate_skin_ = c.candidate_skin;
  wall_work_ = c.wall_work;
  given_energy_ = c.given_energy;
  sorted_at_ = c.sorted_at;
  start_energies_ = c.start;
  state_ = std::move(c.state);
  pairs_ = std::move(c.pairs);
  pairs_stale_ = false;
  pair_contacts_changed();
  wall_contacts_ = std::move(c.walls);
  candidates_ = std::move(c.candidates);
  skin_tracker_.reset(c.reference);
  wall_lists_.clear();  // per slot, and the checkpoint's slots may hold other particles than this world's
  if (!persistent_pairs_ && !state_.slots_follow_ids()) {
    // Saved by a fixed-step Verlet run that re-sorted its particles in space; this run keeps them
    // in id order.
    restore_id_order();
    arena_->execute([&] { rebuild_candidates(); });
  }
  exact_work_.history = std::move(c.exact_history);
  if (spectra_) {
    spectra_->set_books(c.spectra_books);
    for (std::size_t p = 0; p < state_.size(); ++p) spectra_->classify(state_.id[p], state_.radius[p]);
  }
  walls_.set_time(time());
  pairs_.index_rows(state_.size());
  build_pair_adjacency(state_.size(), pairs_, adjacency_);
  adjacency_.wall_start.assign(state_.size() + 1, 0);
  for (std::size_t k = 0; k < wall_contacts_.size(); ++k) ++adjacency_.wall_start[wall_contacts_.particle[k] + 1];
  for (std::size_t p = 0; p < state_.size(); ++p) adjacency_.wall_start[p + 1] += adjacency_.wall_start[p];
}

}  // namespace dem
