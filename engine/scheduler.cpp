#include "engine/scheduler.h"

#include <cmath>

namespace dem {

Scheduler::Scheduler(const IntegratorConfig& c) {
  if (c.control == Control::fixed) {
    level_min_ = level_max_ = 0;
    dt_base_ = c.dt;
  } else {
    level_min_ = c.level_min;
    level_max_ = c.level_max;
    dt_base_ = c.dt_base > 0 ? c.dt_base : c.dt;
  }
  sync_interval_ = step_of_level(level_max_);
}

Real Scheduler::step_of_level(int level) const { return std::ldexp(dt_base_, level); }

Real Scheduler::time(const Clock& clock) const {
  const Real finest = step_of_level(level_min_);
  return origin_ + (static_cast<Real>(clock.interval) * sync_interval_ + static_cast<Real>(clock.tick) * finest);
}

}  // namespace dem
