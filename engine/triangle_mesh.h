#pragma once
// A rigid triangle mesh (a mill liner, a chute) and the contacts of a sphere with it.
// Reads: vertices and triangles (from an STL file or built in code). Writes: nothing after
// construction. Threading: the query is const and safe from any number of threads at once (its
// scratch is thread-local and only grows).
//
// Features. A sphere touches the mesh at faces, edges and vertices, each counted once:
//  * A face contact: the centre's projection onto a triangle's plane lies in the (closed) triangle
//    and the plane is nearer than the radius. Normal: the triangle's normal (towards the centre),
//    overlap: radius minus the distance to the plane, point: the projection.
//  * An edge contact: the nearest point of the edge segment to the centre is nearer than the radius,
//    and no face next to the edge has a face contact. Normal: from that nearest point to the centre.
//  * A vertex contact: the vertex is nearer than the radius, and no edge or face around it has a
//    contact. Normal: from the vertex to the centre.
// So a sphere on a convex edge gets one edge contact, on a convex corner one vertex contact, in a
// concave corner one contact per face, and never a face and its own edge at once.
//
// Flat facets. Triangles joined across edges whose normals are within `flat_angle` of the first
// (lowest-index) triangle of their group form one flat facet: one plane feature however it is
// triangulated. A facet's inner edges and vertices are not features, and a sphere on a facet has one
// face contact whose normal and overlap come from the triangle holding the projection (the most
// inside one when the projection lies on a shared edge, ties to the lower index). So a sphere resting
// or rolling on the shared edge of two coplanar triangles keeps one contact, with one key.
//
// Feature ids (T triangles, E edges, V vertices; feature_count() = T + E + V):
//   face:    the facet's id = the smallest triangle index in the facet, in [0, T)
//            (= the triangle's own index when no neighbour is coplanar)
//   edge e:  T + e, edges numbered by ascending (smaller vertex index, larger vertex index)
//   vertex v: T + E + v
// They depend only on the mesh, so a contact keeps its key while the sphere stays on one feature.
//
// Sides. The front of a triangle is the side its vertex order runs counter-clockwise from (the
// right-hand rule, as in STL). When every edge shared by two triangles is run in opposite directions
// by them and no edge has more than two triangles, the mesh is one-sided: particles live in front
// (a liner's triangles face the charge). A face contact then needs the centre in front of (or on)
// the plane, and an edge or vertex contact needs it in front of at least one adjacent triangle.
// Unlike a plane wall, which also pushes back a centre less than a radius behind it, a face ignores a
// centre behind it: otherwise a sphere on a solid thinner than its diameter (a lifter plate) would be
// pushed through by the far side's face. Overlaps stay below the radius, so nothing is lost in a
// sound run. Otherwise (inconsistent orientation, non-manifold edges) the mesh is two-sided: both
// sides repel, the normal points to the centre's side and the overlap is radius - |distance|.
//
// Lookup. Triangles are binned into a uniform grid of cubic cells (hashed integer cell coordinates,
// as in broadphase/grid.h) covering the cells each triangle actually crosses; a query visits the
// cells of the sphere's bounding box. Cell size: the median triangle extent, doubled while the bins
// would hold more than 16 entries per triangle (giant triangles next to tiny ones).
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "engine/types.h"

namespace dem {

/// One contact of a sphere with a mesh, in the mesh's own frame.
struct MeshContact {
  std::uint32_t feature = 0;  // feature id (see the header comment)
  Vec3 normal;                // unit, from the surface towards the sphere centre
  Real overlap = 0;           // > 0 [m]
  Vec3 point;                 // nearest point of the feature to the centre [m]
};

enum class MeshFeatureKind { face, edge, vertex };

class TriangleMesh {
 public:
  /// Largest angle between a facet's triangle normals and its first triangle's normal [rad].
  static constexpr Real flat_angle = 1e-4;

  /// Takes corner indices (counter-clockwise seen from the front) into `vertices` [m]. Throws
  /// std::invalid_argument for no triangles, an index out of range, a degenerate triangle or a
  /// non-finite coordinate. `cell_size` > 0 overrides the grid's automatic cell size [m].
  TriangleMesh(std::vector<Vec3> vertices, std::vector<std::array<std::uint32_t, 3>> triangles, Real cell_size = 0);

  std::size_t vertex_count() const { return vertices_.size(); }
  std::size_t triangle_count() const { return triangles_.size(); }
  std::size_t edge_count() const { return edges_.size(); }
  std::size_t feature_count() const { return triangle_count() + edge_count() + vertex_count(); }
  const std::vector<Vec3>& vertices() const { return vertices_; }
  const std::vector<std::array<std::uint32_t, 3>>& triangles() const { return triangles_; }
  const std::vector<std::array<std::uint32_t, 2>>& edges() const { return edges_; }
  /// Unit normal of triangle t, on its front side.
  const Vec3& normal(std::size_t t) const { return normal_[t]; }
  /// Facet id (face feature id) of triangle t.
  std::uint32_t facet(std::size_t t) const { return facet_[t]; }
  bool one_sided() const { return one_sided_; }
  MeshFeatureKind feature_kind(std::uint32_t f) const;
  /// Corners of the axis-aligned box around the mesh [m].
  const Vec3& lower() const { return lower_; }
  const Vec3& upper() const { return upper_; }
  /// Edge of the lookup grid's cells [m].
  Real cell_size() const { return cell_size_; }

  /// Contacts of the sphere (centre x, radius r > 0), in the mesh's frame, written to `out` (cleared
  /// first) in ascending feature order. A non-finite centre touches nothing.
  void query(const Vec3& x, Real r, std::vector<MeshContact>& out) const;
  /// The same answer from every triangle instead of the grid's candidates: the tests' oracle.
  void query_all_triangles(const Vec3& x, Real r, std::vector<MeshContact>& out) const;

 private:
  struct Scratch;
  void classify(std::span<const std::uint32_t> candidates, const Vec3& x, Real r, Scratch& scratch,
                std::vector<MeshContact>& out) const;
  void build_edges();
  void build_facets();
  void build_grid(Real cell_size);
  std::array<std::int64_t, 3> cell_of(const Vec3& p) const;
  std::uint64_t cell_key(std::int64_t i, std::int64_t j, std::int64_t k) const;
  std::size_t bucket_of(std::uint64_t key) const;
  bool near_front(const Vec3& x, const Vec3& point, std::span<const std::uint32_t> triangles) const;

  std::vector<Vec3> vertices_;
  std::vector<std::array<std::uint32_t, 3>> triangles_;
  std::vector<Vec3> normal_;                         // per triangle, unit
  std::vector<Real> inverse_double_area_;            // per triangle: 1 / |(b - a) x (c - a)| [1/m^2]
  std::vector<std::array<std::uint32_t, 2>> edges_;  // (smaller, larger) vertex index, ascending
  std::vector<std::array<std::uint32_t, 3>> triangle_edges_;  // edge k runs from corner k to corner k + 1
  std::vector<std::uint32_t> edge_start_, edge_triangle_;      // CSR: triangles on each edge
  std::vector<std::uint32_t> vertex_start_, vertex_triangle_;  // CSR: triangles at each vertex
  std::vector<std::uint32_t> vertex_edge_start_, vertex_edge_;  // CSR: edges at each vertex
  std::vector<std::uint32_t> facet_;                 // per triangle: facet id
  std::vector<bool> edge_is_feature_, vertex_is_feature_;      // false inside a flat facet
  bool one_sided_ = true;
  Vec3 lower_, upper_;
  // Grid: cells sorted by (bucket, key); each lists its triangles ascending.
  Real cell_size_ = 0;
  std::array<std::int64_t, 3> cell_dims_{};       // cells per axis from `lower_`
  std::uint64_t bucket_mask_ = 0;
  std::vector<std::uint32_t> bucket_start_;      // bucket_count + 1 offsets into the cells
  std::vector<std::uint64_t> cell_key_;
  std::vector<std::uint32_t> cell_start_;        // cell_count + 1 offsets into cell_triangle_
  std::vector<std::uint32_t> cell_triangle_;
};

}  // namespace dem
