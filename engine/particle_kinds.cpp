#include "engine/particle_kinds.h"

#include <array>
#include <bit>
#include <utility>

namespace dem {
namespace {

// What a kind names, as bits.
struct KindBits {
  std::uint64_t inv_mass, inv_inertia, radius;
  std::uint16_t material;
  bool operator==(const KindBits&) const = default;
};

KindBits kind_bits(const State& s, std::size_t p) {
  return {std::bit_cast<std::uint64_t>(s.inv_mass[p]), std::bit_cast<std::uint64_t>(s.inv_inertia[p]),
          std::bit_cast<std::uint64_t>(s.radius[p]), s.material[p]};
}

}  // namespace

void assign_particle_kinds(const State& s, std::vector<std::uint32_t>& kind) {
  // The last few kinds seen, replaced in turn: a charge of a few ball sizes finds each particle's kind
  // in a compare or two. A kind that fell out of them and comes back gets a new number, so the
  // numbering stays O(N) however many kinds there are (a scene of all different sizes).
  constexpr std::size_t recent_count = 4;
  std::array<KindBits, recent_count> recent{};
  std::array<std::uint32_t, recent_count> recent_kind{};
  std::size_t filled = 0, replace = 0;
  std::uint32_t next = 0;
  kind.resize(s.size());
  for (std::size_t p = 0; p < s.size(); ++p) {
    const KindBits bits = kind_bits(s, p);
    std::size_t r = 0;
    while (r < filled && !(recent[r] == bits)) ++r;
    if (r == filled) {
      r = filled < recent_count ? filled++ : std::exchange(replace, (replace + 1) % recent_count);
      recent[r] = bits;
      recent_kind[r] = next++;
    }
    kind[p] = recent_kind[r];
  }
}

}  // namespace dem
