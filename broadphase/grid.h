#pragma once
// Hashed uniform grid broadphase.
// Reads: positions [m], radii [m], skin [m]. Writes: a CandidatePairs, and the grid's own scratch buffers.
// Threading: parallel loops (broadphase/parallel.h) inside the caller's task arena; the output is
// bit-identical for every thread count. One object owns its scratch buffers, so it must not run two calls
// at once.
#include "broadphase/candidate_pairs.h"

#include <cstdint>
#include <span>
#include <vector>

namespace dem::broadphase {

/// Candidate pairs from one uniform grid of cubic cells, hashed from integer cell coordinates, so no
/// domain box is needed. Cell size: largest diameter plus skin (widened by a hair so rounding never
/// separates a candidate pair by two cells). A cell's bucket is hash(x, y) + z in a power-of-two table
/// of at least 2n buckets, so the 27 neighbours of a cell lie in at most 9 runs of adjacent buckets.
/// Cost is O(n) for similar sizes; one huge particle makes the cells huge and the search slow, but
/// still correct (KdTreeBroadphase copes better with wide size ranges).
class GridBroadphase {
 public:
  /// Writes into `out` every pair i < j with is_candidate(x_i, r_i, x_j, r_j, skin), as CSR rows in
  /// ascending order. `radii` has one entry per position; skin >= 0 [m]. Buffers (and `out`) are reused,
  /// so nothing is allocated once n and the pair count stop growing. Limits: n < 2^30 and fewer than
  /// 2^32 pairs. Non-finite positions give unspecified pairs but no undefined behaviour.
  void find_pairs(std::span<const Vec3> positions, std::span<const double> radii, double skin, CandidatePairs& out);

  /// Cell edge of the last call [m]; 0 before the first call and after a call with no particles.
  double cell_size() const { return cell_size_; }
  /// Hash buckets of the last call: a power of two, at least 2n (0 after a call with no particles).
  std::size_t bucket_count() const { return bucket_start_.empty() ? 0 : bucket_start_.size() - 1; }
  /// Heap bytes held by the scratch buffers (capacities).
  std::size_t memory_bytes() const;

 private:
  struct Cell {
    std::int64_t x, y, z;
  };
  struct CellBounds {
    Cell lo, hi;  // smallest and largest occupied cell coordinate per axis
  };
  struct Slot {     // a particle's centre and radius, copied into bucket order for sequential reads
    Vec3 position;  // [m]
    double radius;  // [m]
  };

  // Slot ranges holding the up to 27 cells around `cell`: one range per column of three cells, split
  // in two where the table wraps, or one per bucket where two columns' buckets collide. The column
  // hashes and the collision test do not depend on z, so a query in the same column reuses them.
  struct Neighbourhood {
    Cell cell{};
    bool has_columns = false;
    std::int64_t column_x = 0, column_y = 0;  // column the hashes below belong to
    int column_count = 0;
    std::uint64_t column_hash[9];
    bool columns_collide = false;  // some two columns' runs of three buckets share a bucket
    int range_count = 0;
    std::uint32_t begin[27], end[27];
  };

  Cell cell_of(const Vec3& x) const;
  std::uint32_t bucket_of(const Cell& c) const;
  void sort_into_buckets(std::span<const Vec3> positions, std::span<const double> radii);
  void find_neighbourhood(const Cell& cell, Neighbourhood& hood) const;
  bool is_partner(std::size_t t, std::uint32_t u, double skin) const;
  std::uint32_t append_partners(std::size_t t, const Neighbourhood& hood, double skin,
                                std::vector<std::uint32_t>& partners, std::size_t start) const;

  double cell_size_ = 0.0;                   // [m]
  std::uint64_t bucket_mask_ = 0;            // bucket_count - 1
  CellBounds bounds_{};                      // over all particles of the last call
  std::vector<std::uint32_t> bucket_start_;  // bucket_count + 1 offsets into the slots
  std::vector<std::uint32_t> sorted_;        // particle index of each slot: by bucket, ascending within one
  std::vector<Slot> slot_;                   // centre and radius of each slot
  // Scratch of the two-level counting sort (see grid.cpp).
  std::vector<std::uint32_t> bucket_;        // per particle
  std::vector<std::uint32_t> by_super_;      // particle indices by super-bucket
  std::vector<std::uint32_t> block_offset_;  // block_count x super_count counts, then offsets
  std::vector<std::uint32_t> super_start_;   // super_count + 1
  std::vector<CellBounds> block_bounds_;     // per block
  std::vector<std::uint64_t> scan_scratch_;
  std::vector<std::vector<std::uint32_t>> block_partners_;  // per block of queries: its slots' partners
};

}  // namespace dem::broadphase
