#pragma once
// Closed-form propagator of the damped linear oscillator (docs/physics.md 5.1, 5.2, 5.3)
//   delta'' + 2 beta delta' + omega0^2 delta = a,   a constant over the step,
// with omega0 = sqrt(k/m*) [1/s] and beta = c/(2 m*) [1/s]. It is the normal channel of one pair in
// its relative coordinate; a = -(a_i^ext - a_j^ext).n [m/s^2] folds in the body forces.
// The tangential stick channel is the same oscillator with omega0 = sqrt(k_t/m_t) and
// beta = c_t/(2 m_t), the spring elongation xi in place of delta: no separate code.
//
// One code path covers the under-, critically and over-damped regimes and omega0 -> 0 (free
// flight): Phi(h) = e^(-beta h) [C I + S (A + beta I)], where C and S are entire functions of
// z = (omega0^2 - beta^2) h^2 (series for |z| < 1e-3, cos/sin above, exponentials below). Every
// coefficient stays finite at any h >= 0, also for zeta = beta/omega0 = 1e3 and h = 1e6/omega0.
//
// Reads and writes nothing global. The free functions are pure and safe to call from any thread;
// PropagatorTable states its own contract below.
#include <cstdint>
#include <map>
#include <utility>

#include "engine/types.h"

namespace dem {

/// Exact one-step map of the oscillator over a step h:
///   delta(h) = phi11 delta0 + phi12 rate0 + gamma1 a,
///   rate(h)  = phi21 delta0 + phi22 rate0 + gamma2 a     (rate = delta').
/// Units: phi11, phi22 [1]; phi12 [s]; phi21 [1/s]; gamma1 [s^2]; gamma2 [s].
struct PropagatorCoefficients {
  Real phi11, phi12, phi21, phi22, gamma1, gamma2;
};

/// Phi(h) and the forcing column for omega0 >= 0 [1/s], beta >= 0 [1/s], h >= 0 [s].
/// Continuous in (omega0, beta, h) across zeta = 1 and down to omega0 = 0, where it becomes
/// free flight with linear drag: [[1, (1 - e^(-2 beta h))/(2 beta)], [0, e^(-2 beta h)]]
/// ([[1, h], [0, 1]], gamma1 = h^2/2, gamma2 = h for beta = 0 as well).
PropagatorCoefficients propagator(Real omega0, Real beta, Real h);

/// propagator(omega0, beta, h) through a small per-thread memory of the last few distinct arguments:
/// the exact stepper asks for the same coefficients several times in a row (a piece's trial and final
/// normal flow, the two tangential kicks around it). Bit-identical to propagator(); the reference
/// stays valid until this thread's next call.
const PropagatorCoefficients& recent_propagator(Real omega0, Real beta, Real h);

/// First time t > 0 [s] at which the spring-dashpot force k delta + c delta' vanishes
/// (equivalently omega0^2 delta + 2 beta delta' = 0) along the exact trajectory from
/// (delta0 [m], rate0 [m/s]) under constant a [m/s^2]; +infinity if it never does (also for the
/// trivial trajectory with zero force throughout). Whatever the sign of the force at t = 0, the
/// first sign change after it is returned; a zero at t = 0 itself is skipped.
/// a = 0: closed form (docs/physics.md 5.3; from delta0 = 0 this is omega_d t = pi - 2 arctan(beta/omega_d)
/// under-damped, t = 2/omega0 critical, ln((beta+s)/(beta-s))/s over-damped).
/// a != 0: Newton safeguarded by bisection on a bracket between consecutive extrema of the force.
Real force_zero_time(Real omega0, Real beta, Real delta0, Real rate0, Real a);

/// First time t > 0 [s] at which delta = 0 along the same trajectory (the overlap convention of
/// docs/physics.md 2.1); +infinity if never. a = 0: closed form (pi/omega_d from delta0 = 0); a != 0:
/// safeguarded Newton as above.
Real overlap_zero_time(Real omega0, Real beta, Real delta0, Real rate0, Real a);

/// Coefficients cached per (contact class, level), built on demand only for the pairs a scene
/// uses (docs/physics.md 5.2). A level's step is h = dt_base 2^level (docs/physics.md 6.1).
/// Threading contract: get() inserts and is serial only. Call it for every (class, level) a
/// parallel loop needs in a serial step before that loop; inside the loop use the const find(),
/// which only reads the map and is safe from any number of threads while no get() or clear()
/// runs. Entries depend only on their arguments, never on the order of filling, so the table
/// is deterministic. References stay valid until clear() (std::map never moves its nodes).
class PropagatorTable {
 public:
  /// Coefficients of class `cls` at `level`, computed on first use. Later calls for the same key
  /// must pass the same omega0 [1/s], beta [1/s] and dt_base [s] (checked by DEM_ASSERT).
  const PropagatorCoefficients& get(std::uint32_t cls, int level, Real omega0, Real beta, Real dt_base);

  /// Cached coefficients or nullptr; lock-free and const, for use inside parallel loops.
  const PropagatorCoefficients* find(std::uint32_t cls, int level) const;

  std::size_t size() const { return entries_.size(); }
  void clear() { entries_.clear(); }

 private:
  struct Entry {
    Real omega0, beta, h;  // [1/s], [1/s], [s]: the arguments the coefficients were built from
    PropagatorCoefficients coefficients;
  };
  std::map<std::pair<std::uint32_t, int>, Entry> entries_;
};

}  // namespace dem
