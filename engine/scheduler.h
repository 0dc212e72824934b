#pragma once
// Time keeping (docs/design.md, Time). A particle's step is dt_base * 2^level with an integer level in
// [level_min, level_max]; sync intervals last T = dt_base * 2^level_max. Time is the count of
// completed sync intervals plus an integer tick of the finest step inside the current one, never an
// accumulated float. Under the fixed control every particle is at level 0 and T = dt.
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "engine/config.h"

namespace dem {

/// Finest steps (ticks) in one step of `level`.
inline std::int64_t ticks_of_level(int level, int level_min) { return std::int64_t{1} << (level - level_min); }

/// The highest level in [level_min, level_max] whose step dt_base 2^level is at most `step` [s]
/// (level_min when none is).
inline int level_of_step(Real step, Real dt_base, int level_min, int level_max) {
  return static_cast<int>(std::clamp(std::floor(std::log2(step / dt_base)), Real(level_min), Real(level_max)));
}

/// The step that resolves a contact of normal stiffness k between particles whose inverse masses sum
/// to inv_m: t_c / 8, t_c = pi / sqrt(k inv_m).
inline Real contact_resolving_step(Real k, Real inv_m) { return std::acos(-1.0) / std::sqrt(k * inv_m) / 8; }

/// The level of that step.
inline int contact_resolving_level(Real k, Real inv_m, Real dt_base, int level_min, int level_max) {
  return level_of_step(contact_resolving_step(k, inv_m), dt_base, level_min, level_max);
}

/// `level` lowered (not below level_min) until its step starts at `tick` on its own grid and ends by `end`.
inline int aligned_level(int level, int level_min, std::int64_t tick, std::int64_t end) {
  while (level > level_min &&
         (tick % ticks_of_level(level, level_min) != 0 || tick + ticks_of_level(level, level_min) > end))
    --level;
  return level;
}

struct Clock {
  std::int64_t interval = 0;  // completed sync intervals
  std::int64_t tick = 0;      // finest steps into the current interval
};

class Scheduler {
 public:
  Scheduler() = default;
  explicit Scheduler(const IntegratorConfig& config);

  int level_min() const { return level_min_; }
  int level_max() const { return level_max_; }
  Real dt_base() const { return dt_base_; }
  /// Length of a sync interval T [s].
  Real sync_interval() const { return sync_interval_; }
  /// Step of a level [s].
  Real step_of_level(int level) const;
  /// Finest steps per sync interval, 2^(level_max - level_min).
  std::int64_t ticks_per_interval() const { return std::int64_t{1} << (level_max_ - level_min_); }
  /// Physical time of a clock reading [s]: the origin plus its intervals and ticks.
  Real time(const Clock& clock) const;
  /// The time of the clock's zero reading [s]: 0, or the checkpoint's time for a run started from
  /// one under other integrator settings (World::start_from_checkpoint).
  Real origin() const { return origin_; }
  void set_origin(Real origin) { origin_ = origin; }

 private:
  int level_min_ = 0;
  int level_max_ = 0;
  Real dt_base_ = 0;
  Real sync_interval_ = 0;
  Real origin_ = 0;
};

}  // namespace dem
