#include "engine/integrators.h"

#include "engine/parallel.h"

namespace dem {

namespace {

// One particle's kick: v += h (F/m + g), omega += h T/I; immovable particles keep their velocity.
template <bool Rotation, bool Disc>
[[gnu::always_inline]] inline void kick_one(State& s, std::size_t p, Real h, const Vec3& gravity) {
  const Real inv_m = s.inv_mass[p];
  if (inv_m == 0) return;
  s.velocity[p] += h * (inv_m * s.force[p] + gravity);
  if constexpr (Rotation) s.angular_velocity[p] += (h * s.inv_inertia[p]) * s.torque[p];
  if constexpr (Disc) s.velocity[p].z() = 0;
}

// The run's settings are template arguments, so the loop bodies have no branch on them.
template <bool Rotation, bool Disc>
void kick_as(State& s, Real h, const Vec3& gravity) {
  parallel_for(s.size(), [&](std::size_t p) { kick_one<Rotation, Disc>(s, p, h, gravity); });
}

template <bool Rotation, bool Disc>
void kick_drift_as(State& s, Real h_kick, Real h_drift, const Vec3& gravity) {
  parallel_for(s.size(), [&](std::size_t p) {
    kick_one<Rotation, Disc>(s, p, h_kick, gravity);
    s.position[p] += h_drift * s.velocity[p];
  });
}

template <bool Rotation, bool Disc>
KickCheck kick_and_check_as(State& s, Real h_kick, Real h_travel, const Vec3& gravity) {
  return exact_reduce(
      s.size(), default_grain, KickCheck{},
      [&](std::size_t begin, std::size_t end, KickCheck acc) {
        for (std::size_t p = begin; p != end; ++p) {
          kick_one<Rotation, Disc>(s, p, h_kick, gravity);
          acc.finite = acc.finite && particle_is_finite(s, p);
          // Most travels are plainly smaller: only a larger, equal (ties go by id) or NaN one is merged.
          const Worst travel = step_travel(s, p, h_travel);
          if (!(travel.value < acc.travel.value)) acc.travel = Worst::worse(acc.travel, travel);
        }
        return acc;
      },
      [](const KickCheck& a, const KickCheck& b) {
        return KickCheck{a.finite && b.finite, Worst::worse(a.travel, b.travel)};
      });
}

}  // namespace

namespace {

// Calls body.template operator()<Rotation, Disc>() with the run's settings as template arguments.
template <class Body>
decltype(auto) with_settings(bool rotation, int dimension, const Body& body) {
  const bool disc = dimension == 2;
  if (rotation) return disc ? body.template operator()<true, true>() : body.template operator()<true, false>();
  return disc ? body.template operator()<false, true>() : body.template operator()<false, false>();
}

}  // namespace

void kick(State& s, Real h, const Vec3& gravity, bool rotation, int dimension) {
  with_settings(rotation, dimension, [&]<bool Rotation, bool Disc>() { kick_as<Rotation, Disc>(s, h, gravity); });
}

void drift(State& s, Real h) {
  parallel_for(s.size(), [&](std::size_t p) { s.position[p] += h * s.velocity[p]; });
}

void kick_drift(State& s, Real h_kick, Real h_drift, const Vec3& gravity, bool rotation, int dimension) {
  with_settings(rotation, dimension,
                [&]<bool Rotation, bool Disc>() { kick_drift_as<Rotation, Disc>(s, h_kick, h_drift, gravity); });
}

KickCheck kick_and_check(State& s, Real h_kick, Real h_travel, const Vec3& gravity, bool rotation, int dimension) {
  return with_settings(rotation, dimension, [&]<bool Rotation, bool Disc>() {
    return kick_and_check_as<Rotation, Disc>(s, h_kick, h_travel, gravity);
  });
}

}  // namespace dem
