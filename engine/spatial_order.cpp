#include "engine/spatial_order.h"

#include <algorithm>
#include <numeric>
#include <utility>

namespace dem {
namespace {

/// The smallest and the largest coordinates of non-empty `points`, per axis.
std::pair<Vec3, Vec3> bounding_box(std::span<const Vec3> points) {
  Vec3 lo = points[0], hi = lo;
  for (const Vec3& x : points) {
    lo = lo.cwiseMin(x);
    hi = hi.cwiseMax(x);
  }
  return {lo, hi};
}

}  // namespace

std::vector<std::uint32_t> curve_order(std::span<const Vec3> points) {
  std::vector<std::uint32_t> order(points.size());
  if (points.empty()) return order;
  const std::pair<Vec3, Vec3> box = bounding_box(points);
  const Vec3 lo = box.first, hi = box.second;
  const Real side = (hi - lo).maxCoeff();
  constexpr int bits = 10;
  const auto cell = [&](Real x, Real x_lo) {
    const Real fraction = side > 0 ? (x - x_lo) / side : 0;
    return static_cast<std::uint32_t>(std::clamp(fraction, Real{0}, Real{1}) * ((1 << bits) - 1));
  };
  // Key and index in one word: sorting the words sorts by key, ties by index.
  std::vector<std::uint64_t> keyed(points.size());
  for (std::size_t q = 0; q < points.size(); ++q) {
    std::uint64_t key = 0;
    for (int d = 0; d < 3; ++d) {
      const std::uint32_t c = cell(points[q][d], lo[d]);
      for (int b = 0; b < bits; ++b) key |= std::uint64_t{(c >> b) & 1u} << (3 * b + d);
    }
    keyed[q] = key << 32 | q;
  }
  std::sort(keyed.begin(), keyed.end());
  for (std::size_t q = 0; q < keyed.size(); ++q) order[q] = static_cast<std::uint32_t>(keyed[q]);
  return order;
}

std::vector<std::uint32_t> bin_order(std::span<const Vec3> points, Real bin) {
  std::vector<std::uint32_t> order(points.size());
  if (points.empty()) return order;
  // A run about to stop on a non-finite state: leave the order (a NaN has no bin).
  if (!std::all_of(points.begin(), points.end(), [](const Vec3& x) { return x.allFinite(); })) {
    std::iota(order.begin(), order.end(), std::uint32_t{0});
    return order;
  }
  const std::pair<Vec3, Vec3> box = bounding_box(points);
  const Vec3 lo = box.first, hi = box.second;
  constexpr Real max_bins = Real(1 << 21);  // per axis: three axes fit a 64-bit key
  const Real side = std::max({bin, (hi - lo).maxCoeff() / (max_bins - 1), Real{1e-300}});
  const auto bins_along = [&](int d) { return static_cast<std::uint64_t>((hi[d] - lo[d]) / side) + 1; };
  const std::uint64_t nx = bins_along(0), ny = bins_along(1);
  // Key and index in one pair: sorting the pairs sorts by bin, ties by index.
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(points.size());
  for (std::size_t q = 0; q < points.size(); ++q) {
    const Vec3 c = (points[q] - lo) / side;
    const auto ix = static_cast<std::uint64_t>(c.x()), iy = static_cast<std::uint64_t>(c.y());
    const auto iz = static_cast<std::uint64_t>(c.z());
    keyed[q] = {(iz * ny + iy) * nx + ix, static_cast<std::uint32_t>(q)};
  }
  std::sort(keyed.begin(), keyed.end());
  for (std::size_t q = 0; q < keyed.size(); ++q) order[q] = keyed[q].second;
  return order;
}

}  // namespace dem
