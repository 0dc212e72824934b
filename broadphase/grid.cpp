// Hashed uniform grid broadphase (see grid.h).
// Reads: positions [m], radii [m], skin [m]. Writes: CandidatePairs and this object's scratch buffers.
// Threading: every parallel body writes only slots owned by its index or block; the counting sort
// uses count / exclusive scan / fill, and the output queries fixed blocks of slots into buffers of
// their own, scans the counts and copies, so the result does not depend on the thread count.
#include "broadphase/grid.h"

#include "broadphase/parallel.h"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cfloat>
#include <cmath>
#include <limits>
#include <numeric>

namespace dem::broadphase {
namespace {

constexpr std::size_t min_block_size = 4096;   // particles per block of the first sort level, at least
constexpr std::size_t max_block_count = 256;   // bounds the per-block histograms
constexpr std::size_t max_super_count = 1024;  // super-buckets of the first sort level, at most
constexpr std::size_t min_super_size = 256;    // buckets per super-bucket, at least (task granularity)
constexpr std::size_t query_block = 256;      // slots per block of queries

// Cell coordinates are clamped here; the clamp is monotone, so neighbours stay neighbours. With the cell
// size chosen in find_pairs, |x| / cell_size stays below 2^51 anyway; the clamp covers inf and NaN.
constexpr double cell_limit = 4611686018427387904.0;  // 2^62

std::int64_t cell_coordinate(double x, double cell_size) {
  double q = std::floor(x / cell_size);
  if (!(q >= -cell_limit)) q = -cell_limit;  // also maps NaN
  if (q > cell_limit) q = cell_limit;
  return static_cast<std::int64_t>(q);
}

// Hash of a column of cells (x, y): odd 64-bit multipliers and a 64-bit finaliser; wraparound intended.
std::uint64_t column_hash(std::int64_t x, std::int64_t y) {
  std::uint64_t h =
      static_cast<std::uint64_t>(x) * 0x9E3779B97F4A7C15ull ^ static_cast<std::uint64_t>(y) * 0xC2B2AE3D27D4EB4Full;
  h ^= h >> 32;
  h *= 0xD6E8FEB86659FD93ull;
  h ^= h >> 32;
  return h;
}

struct Extent {
  double radius_max = 0.0;      // [m]
  double coordinate_max = 0.0;  // largest |coordinate| [m]
};

}  // namespace

// A cell's bucket is its column's hash plus z: the cells above and below share the column and sit in the
// adjacent buckets, so the 27 neighbours lie in at most 9 runs of consecutive buckets (memory locality).
GridBroadphase::Cell GridBroadphase::cell_of(const Vec3& x) const {
  return {cell_coordinate(x.x(), cell_size_), cell_coordinate(x.y(), cell_size_), cell_coordinate(x.z(), cell_size_)};
}

std::uint32_t GridBroadphase::bucket_of(const Cell& c) const {
  return static_cast<std::uint32_t>((column_hash(c.x, c.y) + static_cast<std::uint64_t>(c.z)) & bucket_mask_);
}

void GridBroadphase::find_pairs(std::span<const Vec3> positions, std::span<const double> radii, double skin,
                                CandidatePairs& out) {
  const std::size_t n = positions.size();
  assert(radii.size() == n);
  assert(skin >= 0.0);
  assert(n < (std::size_t{1} << 30));
  out.row_start.resize(n + 1);
  out.row_start[0] = 0;
  if (n == 0) {
    out.partner.clear();
    cell_size_ = 0.0;
    bucket_start_.clear();
    return;
  }

  // Largest radius and coordinate magnitude: exact max reductions, any split gives the same answer.
  const Extent extent = exact_reduce(
      n, 4096, Extent{},
      [&](std::size_t begin, std::size_t end, Extent e) {
        for (std::size_t i = begin; i < end; ++i) {
          e.radius_max = std::max(e.radius_max, radii[i]);
          e.coordinate_max = std::max(e.coordinate_max, positions[i].cwiseAbs().maxCoeff());
        }
        return e;
      },
      [](Extent a, const Extent& b) {
        a.radius_max = std::max(a.radius_max, b.radius_max);
        a.coordinate_max = std::max(a.coordinate_max, b.coordinate_max);
        return a;
      });

  // Two candidates are at most reach <= 2 r_max + skin apart per axis, but x / cell_size is rounded.
  // Widening the cell by 1e-9 relative plus 8u * max|x| (u = DBL_EPSILON / 2) bounds the rounded
  // difference of two such quotients below 1, so their floors differ by at most one cell; it also keeps
  // |x| / cell_size below 2^51. DBL_MIN covers zero radii with zero skin (only coincident pairs).
  const double reach_max = 2.0 * extent.radius_max + skin;
  cell_size_ = std::max(reach_max * (1.0 + 1e-9) + 4.0 * DBL_EPSILON * extent.coordinate_max, DBL_MIN);

  sort_into_buckets(positions, radii);

  // Rows in one pass of queries and a copy. Queries run in slot order, in fixed blocks of slots, so
  // consecutive queries mostly share a cell (its neighbourhood is then reused) and read neighbouring
  // memory; slot t's partners go to its block's own buffer (ascending), and its count to the row of
  // particle sorted_[t], which no other slot touches. A scan then places the rows, and each block
  // copies its buffer into them. The rows do not depend on the blocks, nor the blocks on the threads.
  const std::size_t block_count = (n + query_block - 1) / query_block;
  if (block_partners_.size() < block_count) block_partners_.resize(block_count);
  std::span<std::uint32_t> counts(out.row_start.data() + 1, n);
  parallel_ranges(block_count, 1, [&](std::size_t b0, std::size_t b1) {
    Neighbourhood hood;
    for (std::size_t b = b0; b < b1; ++b) {
      std::vector<std::uint32_t>& partners = block_partners_[b];
      std::size_t used = 0;
      const std::size_t first = b * query_block, last = std::min(n, first + query_block);
      for (std::size_t t = first; t < last; ++t) {
        const Cell c = cell_of(slot_[t].position);
        if (t == first || c.z != hood.cell.z || c.x != hood.cell.x || c.y != hood.cell.y) find_neighbourhood(c, hood);
        const std::uint32_t count = append_partners(t, hood, skin, partners, used);
        counts[sorted_[t]] = count;
        used += count;
      }
    }
  });
  const std::uint64_t pair_count = detail::inclusive_scan_in_place(counts, scan_scratch_);
  assert(pair_count <= std::numeric_limits<std::uint32_t>::max());
  out.partner.resize(pair_count);
  parallel_ranges(block_count, 1, [&](std::size_t b0, std::size_t b1) {
    for (std::size_t b = b0; b < b1; ++b) {
      const std::uint32_t* from = block_partners_[b].data();
      for (std::size_t t = b * query_block; t < std::min(n, (b + 1) * query_block); ++t) {
        const std::uint32_t i = sorted_[t];
        const std::uint32_t count = out.row_start[i + 1] - out.row_start[i];
        std::copy(from, from + count, out.partner.begin() + out.row_start[i]);
        from += count;
      }
    }
  });
}

std::size_t GridBroadphase::memory_bytes() const {
  const auto bytes = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  return bytes(bucket_start_) + bytes(sorted_) + bytes(slot_) + bytes(bucket_) + bytes(by_super_) +
         bytes(block_offset_) + bytes(super_start_) + bytes(block_bounds_) + bytes(scan_scratch_) +
         block_partners_.capacity() * sizeof(block_partners_[0]) +
         std::accumulate(block_partners_.begin(), block_partners_.end(), std::size_t{0},
                         [&](std::size_t sum, const std::vector<std::uint32_t>& v) { return sum + bytes(v); });
}

// Counting sort of particles by bucket in two levels, so no shared counters are needed:
//  1. fixed-size blocks of particles (the block size depends on n only) count their super-buckets (high
//     bits of the bucket); a serial scan in (super-bucket, block) order turns counts into offsets; each
//     block fills its own ranges in ascending particle order (stable);
//  2. each super-bucket sorts its own particles into its own slice of buckets, serially and stably.
// Result: slots bucket_start_[b] .. bucket_start_[b + 1] hold bucket b's particles, ascending.
void GridBroadphase::sort_into_buckets(std::span<const Vec3> positions, std::span<const double> radii) {
  const std::size_t n = positions.size();
  const std::size_t bucket_count = std::max<std::size_t>(4, std::bit_ceil(2 * n));  // > 3 = longest run
  bucket_mask_ = bucket_count - 1;
  const std::size_t super_count = std::clamp<std::size_t>(bucket_count / min_super_size, 1, max_super_count);
  const int super_shift = std::countr_zero(bucket_count / super_count);
  const std::size_t block_size = std::max(min_block_size, (n + max_block_count - 1) / max_block_count);
  const std::size_t block_count = (n + block_size - 1) / block_size;

  bucket_.resize(n);
  by_super_.resize(n);
  sorted_.resize(n);
  slot_.resize(n);
  bucket_start_.resize(bucket_count + 1);
  super_start_.resize(super_count + 1);
  block_offset_.resize(block_count * super_count);
  block_bounds_.resize(block_count);

  // Level 1, count: buckets, per-block super-bucket histogram and cell bounds.
  parallel_ranges(block_count, 1, [&](std::size_t b0, std::size_t b1) {
    for (std::size_t b = b0; b < b1; ++b) {
      std::uint32_t* histogram = block_offset_.data() + b * super_count;
      std::fill(histogram, histogram + super_count, 0u);
      constexpr std::int64_t big = std::numeric_limits<std::int64_t>::max();
      CellBounds bounds{{big, big, big}, {-big, -big, -big}};
      for (std::size_t i = b * block_size; i < std::min(n, (b + 1) * block_size); ++i) {
        const Cell c = cell_of(positions[i]);
        const std::uint32_t bucket = bucket_of(c);
        bucket_[i] = bucket;
        ++histogram[bucket >> super_shift];
        bounds.lo = {std::min(bounds.lo.x, c.x), std::min(bounds.lo.y, c.y), std::min(bounds.lo.z, c.z)};
        bounds.hi = {std::max(bounds.hi.x, c.x), std::max(bounds.hi.y, c.y), std::max(bounds.hi.z, c.z)};
      }
      block_bounds_[b] = bounds;
    }
  });
  bounds_ = block_bounds_[0];
  for (std::size_t b = 1; b < block_count; ++b) {
    const CellBounds& o = block_bounds_[b];
    bounds_.lo = {std::min(bounds_.lo.x, o.lo.x), std::min(bounds_.lo.y, o.lo.y), std::min(bounds_.lo.z, o.lo.z)};
    bounds_.hi = {std::max(bounds_.hi.x, o.hi.x), std::max(bounds_.hi.y, o.hi.y), std::max(bounds_.hi.z, o.hi.z)};
  }

  // Level 1, scan: super-bucket major, block minor, so earlier blocks (smaller indices) come first.
  std::uint32_t running = 0;
  for (std::size_t s = 0; s < super_count; ++s) {
    super_start_[s] = running;
    for (std::size_t b = 0; b < block_count; ++b) {
      const std::uint32_t count = block_offset_[b * super_count + s];
      block_offset_[b * super_count + s] = running;
      running += count;
    }
  }
  super_start_[super_count] = running;

  // Level 1, fill: each block writes its own ranges, in ascending particle order.
  parallel_ranges(block_count, 1, [&](std::size_t b0, std::size_t b1) {
    for (std::size_t b = b0; b < b1; ++b) {
      std::uint32_t* cursor = block_offset_.data() + b * super_count;
      for (std::size_t i = b * block_size; i < std::min(n, (b + 1) * block_size); ++i) {
        by_super_[cursor[bucket_[i] >> super_shift]++] = static_cast<std::uint32_t>(i);
      }
    }
  });

  // Level 2: each super-bucket owns buckets [s << shift, (s + 1) << shift) and its range of slots.
  const std::size_t buckets_per_super = std::size_t{1} << super_shift;
  parallel_ranges(super_count, 1, [&](std::size_t s0, std::size_t s1) {
    for (std::size_t s = s0; s < s1; ++s) {
      std::uint32_t* start = bucket_start_.data() + s * buckets_per_super;
      std::fill(start, start + buckets_per_super, 0u);
      const std::uint32_t first = super_start_[s];
      const std::uint32_t last = super_start_[s + 1];
      for (std::uint32_t t = first; t < last; ++t) ++bucket_start_[bucket_[by_super_[t]]];
      std::uint32_t end = first;  // inclusive scan: bucket ends
      for (std::size_t q = 0; q < buckets_per_super; ++q) {
        end += start[q];
        start[q] = end;
      }
      // Filling backwards keeps each bucket ascending and leaves each end decremented to its start.
      for (std::uint32_t t = last; t-- > first;) {
        const std::uint32_t i = by_super_[t];
        const std::uint32_t slot = --bucket_start_[bucket_[i]];
        sorted_[slot] = i;
        slot_[slot] = {positions[i], radii[i]};
      }
    }
  });
  bucket_start_[bucket_count] = static_cast<std::uint32_t>(n);
}

void GridBroadphase::find_neighbourhood(const Cell& cell, Neighbourhood& hood) const {
  // Offsets outside the occupied bounds lead to empty cells; skipping them makes 2D inputs cost 9 cells.
  if (!hood.has_columns || cell.x != hood.column_x || cell.y != hood.column_y) {
    hood.has_columns = true;
    hood.column_x = cell.x;
    hood.column_y = cell.y;
    hood.column_count = 0;
    for (std::int64_t x = std::max(cell.x - 1, bounds_.lo.x); x <= std::min(cell.x + 1, bounds_.hi.x); ++x) {
      for (std::int64_t y = std::max(cell.y - 1, bounds_.lo.y); y <= std::min(cell.y + 1, bounds_.hi.y); ++y) {
        hood.column_hash[hood.column_count++] = column_hash(x, y);
      }
    }
    // Runs of three buckets starting at h_a + z and h_b + z share a bucket iff h_a and h_b are less than
    // three apart around the table (rare: hashes collide). Then the buckets are deduplicated one by one,
    // so no partner is visited twice. Shorter runs (at the bounds) share only if these do.
    bool collide = false;
    for (int a = 1; a < hood.column_count; ++a) {
      for (int b = 0; b < a; ++b) collide |= ((hood.column_hash[a] - hood.column_hash[b] + 2) & bucket_mask_) < 5;
    }
    hood.columns_collide = collide;
  }
  hood.cell = cell;
  const std::int64_t z_lo = std::max(cell.z - 1, bounds_.lo.z);
  const std::int64_t z_hi = std::min(cell.z + 1, bounds_.hi.z);
  const auto run = static_cast<std::uint64_t>(z_hi - z_lo + 1);  // buckets per column, 1 to 3
  const int columns = hood.column_count;
  const std::uint64_t* hash = hood.column_hash;
  hood.range_count = 0;
  const auto add = [&](std::uint64_t bucket, std::uint64_t count) {  // buckets [bucket, bucket + count)
    hood.begin[hood.range_count] = bucket_start_[bucket];
    hood.end[hood.range_count] = bucket_start_[bucket + count];
    hood.range_count += hood.end[hood.range_count] > hood.begin[hood.range_count];  // drop empty ones
  };
  const auto first_bucket = [&](int a) { return (hash[a] + static_cast<std::uint64_t>(z_lo)) & bucket_mask_; };
  if (!hood.columns_collide) {
    const std::uint64_t bucket_count = bucket_mask_ + 1;
    for (int a = 0; a < columns; ++a) {
      const std::uint64_t first = first_bucket(a);
      const std::uint64_t before_wrap = std::min(run, bucket_count - first);
      add(first, before_wrap);
      if (before_wrap < run) add(0, run - before_wrap);
    }
    return;
  }
  std::uint64_t buckets[27];
  int m = 0;
  for (int a = 0; a < columns; ++a) {
    for (std::uint64_t q = 0; q < run; ++q) {
      const std::uint64_t bucket = (first_bucket(a) + q) & bucket_mask_;
      if (std::find(buckets, buckets + m, bucket) == buckets + m) buckets[m++] = bucket;
    }
  }
  for (int k = 0; k < m; ++k) add(buckets[k], 1);
}

// The candidate test of slot t against slot u: partner j = sorted_[u] > i and is_candidate.
bool GridBroadphase::is_partner(std::size_t t, std::uint32_t u, double skin) const {
  // Bitwise, not &&: both sides are cheap, and no branch on the first (clang warns of a bool & bool).
  const bool candidate = is_candidate(slot_[t].position, slot_[t].radius, slot_[u].position, slot_[u].radius, skin);
  return static_cast<unsigned>(sorted_[u] > sorted_[t]) & static_cast<unsigned>(candidate);
}

// Writes the partners of slot t into `partners` from index `start`, ascending, and returns their
// count; the vector only grows, so its size is its capacity in use. Branch-free on the test's
// outcome, which goes either way about half the time (the j > i part): each particle of the
// neighbourhood is written at the row's end and kept by advancing the end.
std::uint32_t GridBroadphase::append_partners(std::size_t t, const Neighbourhood& hood, double skin,
                                              std::vector<std::uint32_t>& partners, std::size_t start) const {
  std::size_t room = 0;
  for (int k = 0; k < hood.range_count; ++k) room += hood.end[k] - hood.begin[k];
  if (partners.size() < start + room) partners.resize(start + room);
  std::uint32_t* row = partners.data() + start;
  std::uint32_t count = 0;
  for (int k = 0; k < hood.range_count; ++k) {
    for (std::uint32_t u = hood.begin[k]; u < hood.end[k]; ++u) {
      row[count] = sorted_[u];
      count += is_partner(t, u, skin);
    }
  }
  std::sort(row, row + count);
  return count;
}

}  // namespace dem::broadphase
