#include "engine/checkpoint.h"

#include <cstring>

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
    h.add_vec(s.position[p]);
    h.add_vec(s.velocity[p]);
    h.add_vec(s.angular_velocity[p]);
  }
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    h.add(pairs.key[k]);
    h.add_history(pairs.history[k]);
  }
  for (std::size_t k = 0; k < walls.size(); ++k) {
    h.add(walls.key[k]);
    h.add_history(walls.history[k]);
  }
  return h.value;
}

}  // namespace dem
