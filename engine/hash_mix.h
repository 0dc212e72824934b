#pragma once
// The splitmix64 finaliser: a bijective mix of 64 bits, for counter-based random draws and hashes
// whose value must depend on nothing but their inputs (the same on every run and platform).
#include <cstdint>

namespace dem {

inline std::uint64_t splitmix64_mix(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

}  // namespace dem
