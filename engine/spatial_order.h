#pragma once
// Orders points so that points near each other in space come near each other in the order: the
// generators number their particles along a Morton curve, and a fixed-step run re-sorts its
// particles in memory by bins (World, broadphase.sort_interval).
#include <cstdint>
#include <span>
#include <vector>

#include "engine/types.h"

namespace dem {

/// The indices 0 .. n-1 of `points` in the order of their cells along a Morton (Z-order) curve, ties
/// in index order. Points are quantised to 1,024 cells per axis of their bounding cube, bits
/// interleaved with x lowest.
std::vector<std::uint32_t> curve_order(std::span<const Vec3> points);

/// The indices 0 .. n-1 of `points` by the cubic bin of side `bin` [m] that holds them, bins in
/// row-major order over the points' bounding box (x fastest, then y, then z), ties in index order:
/// a sweep through the bins, as a grid broadphase takes them. The bin grows where the box would need
/// more than 2^21 bins along an axis. With a non-finite coordinate among the points: 0 .. n-1.
std::vector<std::uint32_t> bin_order(std::span<const Vec3> points, Real bin);

}  // namespace dem
