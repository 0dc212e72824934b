// Triangle mesh: connectivity, flat facets, the lookup grid and the sphere query (rules in the header).
#include "engine/triangle_mesh.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>

#include "engine/hash_mix.h"

namespace dem {
namespace {

/// Barycentric slack of the closed-triangle test: a projection this far outside (relative to the
/// triangle) still counts as inside, so one on a shared flat edge is never lost to rounding in both
/// triangles. Across a real edge the face and edge contacts agree there to the same relative order.
constexpr Real inside_tolerance = 1e-10;

/// Grid insertion and lookup pad boxes by this fraction of a cell, so a point computed on a triangle
/// (rounded) is always found in a cell the triangle was binned into.
constexpr Real cell_margin = 1e-6;

struct FaceHit {
  std::uint32_t facet;
  std::uint32_t triangle;
  Real inside;  // smallest barycentric coordinate of the projection
  Real distance;  // signed distance of the centre from the triangle's plane [m]
};

struct PointHit {
  std::uint32_t id;  // edge or vertex index
  Vec3 point;        // nearest point of the feature [m]
};

}  // namespace

struct TriangleMesh::Scratch {
  std::vector<std::uint32_t> candidates;
  std::vector<FaceHit> faces;
  std::vector<PointHit> edges, vertices;
  std::vector<std::uint32_t> face_ids, edge_ids;
};

TriangleMesh::TriangleMesh(std::vector<Vec3> vertices, std::vector<std::array<std::uint32_t, 3>> triangles,
                           Real cell_size)
    : vertices_(std::move(vertices)), triangles_(std::move(triangles)) {
  if (triangles_.empty()) throw std::invalid_argument("a triangle mesh needs at least one triangle");
  if (triangles_.size() >= (std::size_t{1} << 31) || vertices_.size() >= (std::size_t{1} << 31))
    throw std::invalid_argument("a triangle mesh holds fewer than 2^31 triangles and vertices");
  for (const Vec3& v : vertices_)
    if (!v.allFinite()) throw std::invalid_argument("a triangle mesh's vertex coordinates must be finite");
  normal_.resize(triangles_.size());
  inverse_double_area_.resize(triangles_.size());
  lower_ = Vec3::Constant(std::numeric_limits<Real>::infinity());
  upper_ = -lower_;
  for (std::size_t t = 0; t < triangles_.size(); ++t) {
    const auto& c = triangles_[t];
    for (const std::uint32_t v : c) {
      if (v >= vertices_.size())
        throw std::invalid_argument("triangle " + std::to_string(t) + " names vertex " + std::to_string(v) +
                                    " of " + std::to_string(vertices_.size()));
      lower_ = lower_.cwiseMin(vertices_[v]);
      upper_ = upper_.cwiseMax(vertices_[v]);
    }
    const Vec3 cross = (vertices_[c[1]] - vertices_[c[0]]).cross(vertices_[c[2]] - vertices_[c[0]]);
    const Real double_area = cross.norm();
    if (c[0] == c[1] || c[1] == c[2] || c[0] == c[2] || !(double_area > 0) || !std::isfinite(double_area))
      throw std::invalid_argument("triangle " + std::to_string(t) + " is degenerate (zero area)");
    normal_[t] = cross / double_area;
    inverse_double_area_[t] = 1 / double_area;
  }
  build_edges();
  build_facets();
  build_grid(cell_size);
}

MeshFeatureKind TriangleMesh::feature_kind(std::uint32_t f) const {
  if (f < triangle_count()) return MeshFeatureKind::face;
  if (f < triangle_count() + edge_count()) return MeshFeatureKind::edge;
  return MeshFeatureKind::vertex;
}

void TriangleMesh::build_edges() {
  struct Side {
    std::uint32_t lo, hi, triangle, corner;
    bool operator<(const Side& o) const {
      if (lo != o.lo) return lo < o.lo;
      if (hi != o.hi) return hi < o.hi;
      if (triangle != o.triangle) return triangle < o.triangle;
      return corner < o.corner;
    }
  };
  const std::size_t T = triangles_.size();
  std::vector<Side> sides;
  sides.reserve(3 * T);
  for (std::uint32_t t = 0; t < T; ++t)
    for (std::uint32_t k = 0; k < 3; ++k) {
      const std::uint32_t a = triangles_[t][k], b = triangles_[t][(k + 1) % 3];
      sides.push_back({std::min(a, b), std::max(a, b), t, k});
    }
  std::sort(sides.begin(), sides.end());
  triangle_edges_.resize(T);
  edge_start_.assign(1, 0);
  for (std::size_t s = 0; s < sides.size();) {
    std::size_t end = s + 1;
    while (end < sides.size() && sides[end].lo == sides[s].lo && sides[end].hi == sides[s].hi) ++end;
    const auto e = static_cast<std::uint32_t>(edges_.size());
    edges_.push_back({sides[s].lo, sides[s].hi});
    for (std::size_t m = s; m < end; ++m) {
      triangle_edges_[sides[m].triangle][sides[m].corner] = e;
      edge_triangle_.push_back(sides[m].triangle);
    }
    const std::size_t count = end - s;
    if (count > 2) one_sided_ = false;  // non-manifold: no consistent front
    if (count == 2) {
      // Consistent orientation: the two triangles run the shared edge in opposite directions.
      const Side& p = sides[s];
      const Side& q = sides[s + 1];
      const bool p_forward = triangles_[p.triangle][p.corner] == p.lo;
      const bool q_forward = triangles_[q.triangle][q.corner] == q.lo;
      if (p_forward == q_forward) one_sided_ = false;
    }
    edge_start_.push_back(static_cast<std::uint32_t>(edge_triangle_.size()));
    s = end;
  }
  // Vertex -> triangles and vertex -> edges, ascending.
  const std::size_t V = vertices_.size();
  vertex_start_.assign(V + 1, 0);
  for (const auto& c : triangles_)
    for (const std::uint32_t v : c) ++vertex_start_[v + 1];
  for (std::size_t v = 0; v < V; ++v) vertex_start_[v + 1] += vertex_start_[v];
  vertex_triangle_.resize(vertex_start_[V]);
  std::vector<std::uint32_t> cursor(vertex_start_.begin(), vertex_start_.end() - 1);
  for (std::uint32_t t = 0; t < T; ++t)
    for (const std::uint32_t v : triangles_[t]) vertex_triangle_[cursor[v]++] = t;
  vertex_edge_start_.assign(V + 1, 0);
  for (const auto& e : edges_) ++vertex_edge_start_[e[0] + 1], ++vertex_edge_start_[e[1] + 1];
  for (std::size_t v = 0; v < V; ++v) vertex_edge_start_[v + 1] += vertex_edge_start_[v];
  vertex_edge_.resize(vertex_edge_start_[V]);
  cursor.assign(vertex_edge_start_.begin(), vertex_edge_start_.end() - 1);
  for (std::uint32_t e = 0; e < edges_.size(); ++e)
    for (const std::uint32_t v : edges_[e]) vertex_edge_[cursor[v]++] = e;
}

void TriangleMesh::build_facets() {
  const std::size_t T = triangles_.size();
  const Real min_cos = std::cos(flat_angle);
  constexpr std::uint32_t none = std::numeric_limits<std::uint32_t>::max();
  facet_.assign(T, none);
  std::vector<std::uint32_t> stack;
  for (std::uint32_t seed = 0; seed < T; ++seed) {
    if (facet_[seed] != none) continue;
    facet_[seed] = seed;
    stack.assign(1, seed);
    while (!stack.empty()) {
      const std::uint32_t u = stack.back();
      stack.pop_back();
      for (const std::uint32_t e : triangle_edges_[u]) {
        if (edge_start_[e + 1] - edge_start_[e] != 2) continue;  // boundary or non-manifold: a real edge
        const std::uint32_t w = edge_triangle_[edge_start_[e]] == u ? edge_triangle_[edge_start_[e] + 1]
                                                                      : edge_triangle_[edge_start_[e]];
        if (facet_[w] != none) continue;
        const Real c = normal_[w].dot(normal_[seed]);
        if ((one_sided_ ? c : std::abs(c)) < min_cos) continue;
        facet_[w] = seed;
        stack.push_back(w);
      }
    }
  }
  edge_is_feature_.assign(edges_.size(), true);
  for (std::size_t e = 0; e < edges_.size(); ++e)
    if (edge_start_[e + 1] - edge_start_[e] == 2 &&
        facet_[edge_triangle_[edge_start_[e]]] == facet_[edge_triangle_[edge_start_[e] + 1]])
      edge_is_feature_[e] = false;
  vertex_is_feature_.assign(vertices_.size(), false);
  for (std::size_t v = 0; v < vertices_.size(); ++v)
    for (std::uint32_t k = vertex_edge_start_[v]; k < vertex_edge_start_[v + 1]; ++k)
      if (edge_is_feature_[vertex_edge_[k]]) vertex_is_feature_[v] = true;
}

std::array<std::int64_t, 3> TriangleMesh::cell_of(const Vec3& p) const {
  std::array<std::int64_t, 3> c;
  for (int a = 0; a < 3; ++a) {
    const Real u = std::floor((p[a] - lower_[a]) / cell_size_);
    // Clamped before the conversion, so a far-off (or non-finite) point is never undefined behaviour.
    c[a] = u >= 0 ? (u < static_cast<Real>(cell_dims_[a]) ? static_cast<std::int64_t>(u) : cell_dims_[a] - 1) : 0;
  }
  return c;
}

std::uint64_t TriangleMesh::cell_key(std::int64_t i, std::int64_t j, std::int64_t k) const {
  return static_cast<std::uint64_t>(i) +
         static_cast<std::uint64_t>(cell_dims_[0]) *
             (static_cast<std::uint64_t>(j) + static_cast<std::uint64_t>(cell_dims_[1]) * static_cast<std::uint64_t>(k));
}

std::size_t TriangleMesh::bucket_of(std::uint64_t key) const { return static_cast<std::size_t>(splitmix64_mix(key) & bucket_mask_); }

void TriangleMesh::build_grid(Real cell_size) {
  const std::size_t T = triangles_.size();
  std::vector<Real> extent(T);
  for (std::size_t t = 0; t < T; ++t) {
    const auto& c = triangles_[t];
    const Vec3 lo = vertices_[c[0]].cwiseMin(vertices_[c[1]]).cwiseMin(vertices_[c[2]]);
    const Vec3 hi = vertices_[c[0]].cwiseMax(vertices_[c[1]]).cwiseMax(vertices_[c[2]]);
    extent[t] = (hi - lo).maxCoeff();
  }
  Real h = cell_size;
  if (!(h > 0)) {
    std::nth_element(extent.begin(), extent.begin() + static_cast<std::ptrdiff_t>(T / 2), extent.end());
    h = extent[T / 2];
  }
  // At most 2^20 cells per axis, so a cell's linear key fits 64 bits.
  const Real span = (upper_ - lower_).maxCoeff();
  h = std::max(h, span / Real(1 << 20));
  if (!(h > 0)) h = 1;

  // Cells each triangle crosses: those of its padded box whose centre lies within half a cell
  // diagonal (padded) of its plane. `visit(t, i, j, k)` is called for each.
  auto for_each_cell = [&](auto&& visit) {
    const Real pad = cell_margin * cell_size_;
    const Real reach = (0.5 * std::sqrt(Real(3)) + cell_margin) * cell_size_;
    for (std::uint32_t t = 0; t < T; ++t) {
      const auto& c = triangles_[t];
      const Vec3 lo = vertices_[c[0]].cwiseMin(vertices_[c[1]]).cwiseMin(vertices_[c[2]]) - Vec3::Constant(pad);
      const Vec3 hi = vertices_[c[0]].cwiseMax(vertices_[c[1]]).cwiseMax(vertices_[c[2]]) + Vec3::Constant(pad);
      const auto a = cell_of(lo), b = cell_of(hi);
      for (std::int64_t k = a[2]; k <= b[2]; ++k)
        for (std::int64_t j = a[1]; j <= b[1]; ++j)
          for (std::int64_t i = a[0]; i <= b[0]; ++i) {
            const Vec3 centre = lower_ + cell_size_ * Vec3(Real(i) + 0.5, Real(j) + 0.5, Real(k) + 0.5);
            if (std::abs((centre - vertices_[c[0]]).dot(normal_[t])) <= reach) visit(t, i, j, k);
          }
    }
  };
  // Giant triangles next to small ones would fill many cells: widen the cells until the bins hold
  // at most 16 entries per triangle on average.
  std::size_t entries = 0;
  for (;;) {
    cell_size_ = h;
    for (int a = 0; a < 3; ++a) cell_dims_[a] = static_cast<std::int64_t>(std::floor((upper_[a] - lower_[a]) / h)) + 1;
    entries = 0;
    const std::size_t limit = 16 * T + 1024;
    bool too_many = false;
    for_each_cell([&](std::uint32_t, std::int64_t, std::int64_t, std::int64_t) { too_many = ++entries > limit; });
    if (!too_many) break;
    h *= 2;
  }
  std::vector<std::pair<std::uint64_t, std::uint32_t>> binned;
  binned.reserve(entries);
  for_each_cell([&](std::uint32_t t, std::int64_t i, std::int64_t j, std::int64_t k) {
    binned.emplace_back(cell_key(i, j, k), t);
  });
  std::sort(binned.begin(), binned.end());
  // Distinct cells, each with its run of triangles (ascending).
  std::vector<std::uint64_t> keys;
  std::vector<std::uint32_t> run_start;
  for (std::size_t m = 0; m < binned.size(); ++m)
    if (m == 0 || binned[m].first != binned[m - 1].first) {
      keys.push_back(binned[m].first);
      run_start.push_back(static_cast<std::uint32_t>(m));
    }
  run_start.push_back(static_cast<std::uint32_t>(binned.size()));
  std::size_t bucket_count = 1;
  while (bucket_count < 2 * keys.size()) bucket_count *= 2;
  bucket_mask_ = bucket_count - 1;
  std::vector<std::uint32_t> order(keys.size());
  for (std::size_t c = 0; c < keys.size(); ++c) order[c] = static_cast<std::uint32_t>(c);
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    const std::size_t ba = bucket_of(keys[a]), bb = bucket_of(keys[b]);
    return ba != bb ? ba < bb : keys[a] < keys[b];
  });
  bucket_start_.assign(bucket_count + 1, 0);
  cell_key_.clear();
  cell_start_.assign(1, 0);
  cell_triangle_.clear();
  cell_triangle_.reserve(binned.size());
  for (const std::uint32_t c : order) {
    ++bucket_start_[bucket_of(keys[c]) + 1];
    cell_key_.push_back(keys[c]);
    for (std::uint32_t m = run_start[c]; m < run_start[c + 1]; ++m) cell_triangle_.push_back(binned[m].second);
    cell_start_.push_back(static_cast<std::uint32_t>(cell_triangle_.size()));
  }
  for (std::size_t b = 0; b < bucket_count; ++b) bucket_start_[b + 1] += bucket_start_[b];
}

void TriangleMesh::query(const Vec3& x, Real r, std::vector<MeshContact>& out) const {
  out.clear();
  if (!(r > 0) || !x.allFinite() || !std::isfinite(r)) return;
  const Vec3 pad = Vec3::Constant(r + cell_margin * cell_size_);
  const Vec3 lo = x - pad, hi = x + pad;
  if ((lo.array() > upper_.array()).any() || (hi.array() < lower_.array()).any()) return;
  thread_local Scratch scratch;
  scratch.candidates.clear();
  const auto a = cell_of(lo), b = cell_of(hi);
  for (std::int64_t k = a[2]; k <= b[2]; ++k)
    for (std::int64_t j = a[1]; j <= b[1]; ++j)
      for (std::int64_t i = a[0]; i <= b[0]; ++i) {
        const std::uint64_t key = cell_key(i, j, k);
        const std::size_t bucket = bucket_of(key);
        for (std::uint32_t c = bucket_start_[bucket]; c < bucket_start_[bucket + 1]; ++c)
          if (cell_key_[c] == key)
            scratch.candidates.insert(scratch.candidates.end(), cell_triangle_.begin() + cell_start_[c],
                                      cell_triangle_.begin() + cell_start_[c + 1]);
      }
  std::sort(scratch.candidates.begin(), scratch.candidates.end());
  scratch.candidates.erase(std::unique(scratch.candidates.begin(), scratch.candidates.end()), scratch.candidates.end());
  classify(scratch.candidates, x, r, scratch, out);
}

void TriangleMesh::query_all_triangles(const Vec3& x, Real r, std::vector<MeshContact>& out) const {
  out.clear();
  if (!(r > 0) || !x.allFinite() || !std::isfinite(r)) return;
  thread_local Scratch scratch;
  scratch.candidates.resize(triangles_.size());
  for (std::size_t t = 0; t < triangles_.size(); ++t) scratch.candidates[t] = static_cast<std::uint32_t>(t);
  classify(scratch.candidates, x, r, scratch, out);
}

bool TriangleMesh::near_front(const Vec3& x, const Vec3& point, std::span<const std::uint32_t> triangles) const {
  if (!one_sided_) return true;
  const Vec3 d = x - point;
  for (const std::uint32_t t : triangles)
    if (d.dot(normal_[t]) >= 0) return true;
  return false;
}

void TriangleMesh::classify(std::span<const std::uint32_t> candidates, const Vec3& x, Real r, Scratch& s,
                            std::vector<MeshContact>& out) const {
  s.faces.clear();
  s.edges.clear();
  s.vertices.clear();
  const Real r2 = r * r;
  for (const std::uint32_t t : candidates) {
    const auto& c = triangles_[t];
    const Vec3& p0 = vertices_[c[0]];
    const Vec3& p1 = vertices_[c[1]];
    const Vec3& p2 = vertices_[c[2]];
    const Vec3& n = normal_[t];
    const Real d = (x - p0).dot(n);
    // Every point of the triangle lies in its plane: a plane a radius away rules out all its features.
    if (!(std::abs(d) < r)) continue;
    // Barycentric coordinates of the projection (the plane's normal component drops out).
    const Real w = inverse_double_area_[t];
    const Real l0 = (p2 - p1).cross(x - p1).dot(n) * w;
    const Real l1 = (p0 - p2).cross(x - p2).dot(n) * w;
    const Real l2 = (p1 - p0).cross(x - p0).dot(n) * w;
    const Real inside = std::min({l0, l1, l2});
    if (inside >= -inside_tolerance) {
      // The face covers this triangle's own edges and corners: nothing more to look at here.
      if (!one_sided_ || d >= 0) s.faces.push_back({facet_[t], t, inside, d});
      continue;
    }
    for (const std::uint32_t e : triangle_edges_[t]) {
      if (!edge_is_feature_[e]) continue;
      // From the edge's own (ordered) ends, so both of its triangles find bitwise the same point.
      const Vec3& q0 = vertices_[edges_[e][0]];
      const Vec3 along = vertices_[edges_[e][1]] - q0;
      const Real u = (x - q0).dot(along) / along.squaredNorm();
      if (!(u >= 0 && u <= 1)) continue;  // the nearest point is an end: a vertex's business
      const Vec3 point = q0 + u * along;
      if ((x - point).squaredNorm() < r2) s.edges.push_back({e, point});
    }
    for (const std::uint32_t v : c)
      if (vertex_is_feature_[v] && (x - vertices_[v]).squaredNorm() < r2) s.vertices.push_back({v, vertices_[v]});
  }

  // Faces: one contact per facet, from its triangle holding the projection most inside.
  std::sort(s.faces.begin(), s.faces.end(), [](const FaceHit& a, const FaceHit& b) {
    if (a.facet != b.facet) return a.facet < b.facet;
    if (a.inside != b.inside) return a.inside > b.inside;
    return a.triangle < b.triangle;
  });
  s.face_ids.clear();
  for (std::size_t k = 0; k < s.faces.size(); ++k) {
    const FaceHit& f = s.faces[k];
    if (k > 0 && f.facet == s.faces[k - 1].facet) continue;
    s.face_ids.push_back(f.facet);
    const Vec3& n = normal_[f.triangle];
    MeshContact m;
    m.feature = f.facet;
    m.normal = (f.distance >= 0 || one_sided_) ? n : Vec3(-n);
    m.overlap = r - (one_sided_ ? f.distance : std::abs(f.distance));
    m.point = x - f.distance * n;
    out.push_back(m);
  }
  auto has_face = [&](std::uint32_t facet) { return std::binary_search(s.face_ids.begin(), s.face_ids.end(), facet); };
  auto by_id = [](const PointHit& a, const PointHit& b) { return a.id < b.id; };
  auto same_id = [](const PointHit& a, const PointHit& b) { return a.id == b.id; };
  // Unit normal from `point` to the centre; on the feature itself, the mean of its triangles' normals.
  auto normal_from = [&](const Vec3& point, std::span<const std::uint32_t> triangles) {
    const Vec3 d = x - point;
    const Real length = d.norm();
    if (length > 0) return Vec3(d / length);
    Vec3 sum = Vec3::Zero();
    for (const std::uint32_t t : triangles) sum += normal_[t];
    return sum.norm() > 0 ? Vec3(sum.normalized()) : normal_[triangles[0]];
  };

  // Edges: unless a face next to them touches.
  std::sort(s.edges.begin(), s.edges.end(), by_id);
  s.edges.erase(std::unique(s.edges.begin(), s.edges.end(), same_id), s.edges.end());
  s.edge_ids.clear();
  const auto T = static_cast<std::uint32_t>(triangles_.size());
  const auto E = static_cast<std::uint32_t>(edges_.size());
  for (const PointHit& h : s.edges) {
    const std::span<const std::uint32_t> around(edge_triangle_.data() + edge_start_[h.id],
                                                edge_start_[h.id + 1] - edge_start_[h.id]);
    bool covered = false;
    for (const std::uint32_t t : around) covered = covered || has_face(facet_[t]);
    if (covered || !near_front(x, h.point, around)) continue;
    s.edge_ids.push_back(h.id);
    const Real distance = (x - h.point).norm();
    out.push_back({T + h.id, normal_from(h.point, around), r - distance, h.point});
  }
  // Vertices: unless an edge or a face around them touches.
  std::sort(s.vertices.begin(), s.vertices.end(), by_id);
  s.vertices.erase(std::unique(s.vertices.begin(), s.vertices.end(), same_id), s.vertices.end());
  for (const PointHit& h : s.vertices) {
    const std::span<const std::uint32_t> around(vertex_triangle_.data() + vertex_start_[h.id],
                                                vertex_start_[h.id + 1] - vertex_start_[h.id]);
    bool covered = false;
    for (const std::uint32_t t : around) covered = covered || has_face(facet_[t]);
    for (std::uint32_t k = vertex_edge_start_[h.id]; k < vertex_edge_start_[h.id + 1]; ++k)
      covered = covered || std::binary_search(s.edge_ids.begin(), s.edge_ids.end(), vertex_edge_[k]);
    if (covered || !near_front(x, h.point, around)) continue;
    const Real distance = (x - h.point).norm();
    out.push_back({T + E + h.id, normal_from(h.point, around), r - distance, h.point});
  }
}

}  // namespace dem
