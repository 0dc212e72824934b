// k-d tree broadphase over nanoflann 1.4 (see kd_tree.h).
// Reads: positions [m], radii [m], skin [m]. Writes: CandidatePairs and the tree.
// Threading: serial build; queries in parallel, each writing only its own row (count / scan / fill), so
// the result does not depend on the thread count. nanoflann's const queries are safe to run concurrently.
#include "broadphase/kd_tree.h"

#include "broadphase/parallel.h"

#include <nanoflann.hpp>

#include <algorithm>
#include <cassert>
#include <cfloat>
#include <limits>

namespace dem::broadphase {
namespace {

// nanoflann's dataset-adaptor concept, over the caller's span.
struct PointCloud {
  std::span<const Vec3> points;

  std::size_t kdtree_get_point_count() const { return points.size(); }
  double kdtree_get_pt(std::uint32_t i, std::size_t axis) const { return points[i][static_cast<Eigen::Index>(axis)]; }
  template <class BoundingBox>
  bool kdtree_get_bbox(BoundingBox&) const {
    return false;  // let nanoflann compute it
  }
};

using Metric = nanoflann::L2_Simple_Adaptor<double, PointCloud, double, std::uint32_t>;
using Index = nanoflann::KDTreeSingleIndexAdaptor<Metric, PointCloud, 3, std::uint32_t>;

constexpr std::size_t leaf_size = 16;
constexpr std::size_t query_grain = 256;

// nanoflann's result-set concept (worstDist, addPoint, full, size). Instead of collecting (index,
// distance) pairs it applies the shared predicate at once, and either counts or writes the partners.
class PartnerSink {
 public:
  PartnerSink(std::uint32_t i, std::span<const Vec3> positions, std::span<const double> radii, double skin,
              double search_radius_sq, std::uint32_t* row)
      : i_(i), positions_(positions), radii_(radii), skin_(skin), search_radius_sq_(search_radius_sq), row_(row) {}

  double worstDist() const { return search_radius_sq_; }
  bool full() const { return true; }
  std::size_t size() const { return count_; }
  bool addPoint(double, std::uint32_t j) {
    if (j > i_ && is_candidate(positions_[i_], radii_[i_], positions_[j], radii_[j], skin_)) {
      if (row_ != nullptr) row_[count_] = j;
      ++count_;
    }
    return true;  // keep searching
  }

 private:
  std::uint32_t i_;
  std::span<const Vec3> positions_;
  std::span<const double> radii_;
  double skin_;
  double search_radius_sq_;  // [m^2]
  std::uint32_t* row_;       // null in the counting pass
  std::uint32_t count_ = 0;
};

}  // namespace

struct KdTreeBroadphase::Tree {
  PointCloud cloud;
  Index index{3, cloud,
              nanoflann::KDTreeSingleIndexAdaptorParams(
                  leaf_size, nanoflann::KDTreeSingleIndexAdaptorFlags::SkipInitialBuildIndex)};
};

KdTreeBroadphase::KdTreeBroadphase() : tree_(std::make_unique<Tree>()) {}
KdTreeBroadphase::~KdTreeBroadphase() = default;
KdTreeBroadphase::KdTreeBroadphase(KdTreeBroadphase&&) noexcept = default;
KdTreeBroadphase& KdTreeBroadphase::operator=(KdTreeBroadphase&&) noexcept = default;

std::size_t KdTreeBroadphase::memory_bytes() const {
  const Index& index = tree_->index;
  return index.pool.usedMemory + index.pool.wastedMemory + index.vAcc.capacity() * sizeof(std::uint32_t) +
         scan_scratch_.capacity() * sizeof(std::uint64_t);
}

void KdTreeBroadphase::find_pairs(std::span<const Vec3> positions, std::span<const double> radii, double skin,
                                  CandidatePairs& out) {
  const std::size_t n = positions.size();
  assert(radii.size() == n);
  assert(skin >= 0.0);
  assert(n < std::numeric_limits<std::uint32_t>::max());
  out.row_start.resize(n + 1);
  out.row_start[0] = 0;
  if (n == 0) {
    out.partner.clear();
    return;
  }

  const double radius_max = exact_reduce(  // exact max: any split gives the same answer
      n, 4096, 0.0,
      [&](std::size_t begin, std::size_t end, double m) {
        for (std::size_t i = begin; i < end; ++i) m = std::max(m, radii[i]);
        return m;
      },
      [](double a, double b) { return std::max(a, b); });

  tree_->cloud.points = positions;
  tree_->index.buildIndex();

  // nanoflann keeps points with distance^2 strictly below the radius^2, and prunes with bounds rounded
  // differently from is_candidate; widening by 1e-9 relative (plus DBL_MIN for a zero reach, where only
  // coincident points qualify) makes every true candidate reach the predicate.
  const auto search_radius_sq = [&](std::size_t i) {
    const double reach = radii[i] + radius_max + skin;  // >= r_i + r_j + skin, as sums round monotonically
    return reach * reach * (1.0 + 1e-9) + DBL_MIN;
  };
  const auto search = [&](std::size_t i, std::uint32_t* row) {
    PartnerSink sink(static_cast<std::uint32_t>(i), positions, radii, skin, search_radius_sq(i), row);
    tree_->index.findNeighbors(sink, positions[i].data(), nanoflann::SearchParams(32, 0.0f, false));
    return static_cast<std::uint32_t>(sink.size());
  };

  // Queries run in the tree's leaf order, so consecutive queries walk the same branches (cache); query q
  // owns the row of particle order[q], which no other query touches.
  const std::vector<std::uint32_t>& order = tree_->index.vAcc;
  std::span<std::uint32_t> counts(out.row_start.data() + 1, n);
  parallel_ranges(n, query_grain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t q = begin; q < end; ++q) counts[order[q]] = search(order[q], nullptr);
  });
  const std::uint64_t pair_count = detail::inclusive_scan_in_place(counts, scan_scratch_);
  assert(pair_count <= std::numeric_limits<std::uint32_t>::max());
  out.partner.resize(pair_count);
  parallel_ranges(n, query_grain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t q = begin; q < end; ++q) {
      std::uint32_t* row = out.partner.data() + out.row_start[order[q]];
      std::sort(row, row + search(order[q], row));
    }
  });
  tree_->cloud.points = {};  // the tree must not outlive the caller's positions unnoticed
}

}  // namespace dem::broadphase
