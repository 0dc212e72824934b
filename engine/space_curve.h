#pragma once
// Orders points along a Morton (Z-order) curve, so that points near each other in space come near
// each other in the order: the generators number their particles by it, and a fixed-step run
// re-sorts its particles in memory by it (World, broadphase.sort_interval).
#include <cstdint>
#include <span>
#include <vector>

#include "engine/types.h"

namespace dem {

/// The indices 0 .. n-1 of `points` in the order of their cells along a Morton curve, ties in index
/// order. Points are quantised to 1,024 cells per axis of their bounding cube, bits interleaved with
/// x lowest. Depends on the points alone (a serial sort), so on nothing else in a run.
std::vector<std::uint32_t> curve_order(std::span<const Vec3> points);

}  // namespace dem
