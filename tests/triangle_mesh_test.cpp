// Sphere-mesh contacts: faces, edges and vertices counted once, against analytic geometry; the
// lookup grid against the all-triangles oracle.
#include "engine/triangle_mesh.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/Geometry>

namespace dem {
namespace {

using Triangles = std::vector<std::array<std::uint32_t, 3>>;

/// Cube [0, 1]^3 with outward-facing triangles; each square face split along the diagonal from its
/// first corner.
TriangleMesh unit_cube() {
  std::vector<Vec3> p = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  const int q[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {2, 3, 7, 6}, {1, 2, 6, 5}, {0, 4, 7, 3}};
  Triangles t;
  for (const auto& f : q) {
    t.push_back({std::uint32_t(f[0]), std::uint32_t(f[1]), std::uint32_t(f[2])});
    t.push_back({std::uint32_t(f[0]), std::uint32_t(f[2]), std::uint32_t(f[3])});
  }
  return TriangleMesh(p, t);
}

/// The square [0, 2] x [0, 2] at z = 0, facing +z, split along its diagonal (0, 0)-(2, 2).
TriangleMesh floor_square() {
  return TriangleMesh({{0, 0, 0}, {2, 0, 0}, {2, 2, 0}, {0, 2, 0}}, {{0, 1, 2}, {0, 2, 3}});
}

std::vector<MeshContact> contacts(const TriangleMesh& m, const Vec3& x, Real r) {
  std::vector<MeshContact> out;
  m.query(x, r, out);
  std::vector<MeshContact> oracle;
  m.query_all_triangles(x, r, oracle);
  EXPECT_EQ(out.size(), oracle.size());
  return out;
}

void expect_near(const Vec3& a, const Vec3& b, Real tolerance = 1e-14) {
  EXPECT_LT((a - b).norm(), tolerance) << a.transpose() << " vs " << b.transpose();
}

TEST(TriangleMesh, CubeConnectivityFacetsAndFeatureIds) {
  const TriangleMesh cube = unit_cube();
  EXPECT_EQ(cube.triangle_count(), 12u);
  EXPECT_EQ(cube.vertex_count(), 8u);
  EXPECT_EQ(cube.edge_count(), 18u);  // 12 cube edges and 6 face diagonals
  EXPECT_EQ(cube.feature_count(), 38u);
  EXPECT_TRUE(cube.one_sided());
  for (std::uint32_t t = 0; t < 12; t += 2) {  // the two halves of a square are one flat facet
    EXPECT_EQ(cube.facet(t), t);
    EXPECT_EQ(cube.facet(t + 1), t);
  }
  EXPECT_EQ(cube.feature_kind(11), MeshFeatureKind::face);
  EXPECT_EQ(cube.feature_kind(12), MeshFeatureKind::edge);
  EXPECT_EQ(cube.feature_kind(29), MeshFeatureKind::edge);
  EXPECT_EQ(cube.feature_kind(30), MeshFeatureKind::vertex);
  for (std::size_t t = 0; t < 12; ++t) {  // outward normals
    const auto& c = cube.triangles()[t];
    const Vec3 centroid = (cube.vertices()[c[0]] + cube.vertices()[c[1]] + cube.vertices()[c[2]]) / 3;
    EXPECT_GT(cube.normal(t).dot(centroid - Vec3::Constant(0.5)), 0);
  }
}

TEST(TriangleMesh, SphereOnAFaceHasOneFaceContact) {
  const TriangleMesh cube = unit_cube();
  const auto c = contacts(cube, Vec3(0.7, 0.2, 1.08), 0.1);
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c[0].feature, 2u);  // top: triangles 2 and 3
  expect_near(c[0].normal, Vec3::UnitZ());
  EXPECT_NEAR(c[0].overlap, 0.02, 1e-15);
  expect_near(c[0].point, Vec3(0.7, 0.2, 1));
  // Near an edge of the face, but above the face: still the face alone.
  const auto near_edge = contacts(cube, Vec3(0.98, 0.5, 1.05), 0.1);
  ASSERT_EQ(near_edge.size(), 1u);
  EXPECT_EQ(near_edge[0].feature, 2u);
  EXPECT_NEAR(near_edge[0].overlap, 0.05, 1e-15);
}

TEST(TriangleMesh, SphereOnTheSharedEdgeOfCoplanarTrianglesHasOneContact) {
  const TriangleMesh floor = floor_square();
  EXPECT_EQ(floor.facet(1), 0u);
  for (const Real offset : {0.0, 1e-17, -1e-17, 1e-9, -1e-9, 0.3, -0.3}) {
    const Vec3 x(1 + offset, 1 - offset, 0.09);  // across the diagonal (0, 0)-(2, 2)
    const auto c = contacts(floor, x, 0.1);
    ASSERT_EQ(c.size(), 1u) << offset;
    EXPECT_EQ(c[0].feature, 0u);
    EXPECT_EQ(c[0].normal, Vec3::UnitZ());
    EXPECT_NEAR(c[0].overlap, 0.01, 1e-16);
  }
  // On the shared corner (0, 0) of the two triangles: one face contact too (the corner is on the rim).
  const auto corner = contacts(floor, Vec3(1e-3, 1e-3, 0.05), 0.1);
  ASSERT_EQ(corner.size(), 1u);
  EXPECT_EQ(corner[0].feature, 0u);
}

TEST(TriangleMesh, SphereOnAConvexEdgeHasOneEdgeContactAlongTheBisector) {
  const TriangleMesh cube = unit_cube();
  const Real r = 0.1, s = 0.05;
  const auto c = contacts(cube, Vec3(0.4, 1 + s, 1 + s), r);  // beyond the edge y = z = 1
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(cube.feature_kind(c[0].feature), MeshFeatureKind::edge);
  const auto& e = cube.edges()[c[0].feature - cube.triangle_count()];
  EXPECT_EQ(cube.vertices()[e[0]].tail<2>(), Eigen::Vector2d(1, 1));
  EXPECT_EQ(cube.vertices()[e[1]].tail<2>(), Eigen::Vector2d(1, 1));
  expect_near(c[0].normal, Vec3(0, 1, 1).normalized());
  EXPECT_NEAR(c[0].overlap, r - s * std::sqrt(2.0), 1e-15);
  expect_near(c[0].point, Vec3(0.4, 1, 1));
  // Off the bisector: normal still from the edge to the centre.
  const auto off = contacts(cube, Vec3(0.4, 1.02, 1.06), r);
  ASSERT_EQ(off.size(), 1u);
  expect_near(off[0].normal, Vec3(0, 0.02, 0.06).normalized());
  EXPECT_NEAR(off[0].overlap, r - std::hypot(0.02, 0.06), 1e-15);
}

TEST(TriangleMesh, SphereOnACubeCornerHasOneVertexContact) {
  const TriangleMesh cube = unit_cube();
  const auto c = contacts(cube, Vec3(1.04, 1.04, 1.04), 0.1);
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c[0].feature, cube.triangle_count() + cube.edge_count() + 6);  // vertex (1, 1, 1)
  expect_near(c[0].normal, Vec3(1, 1, 1).normalized());
  EXPECT_NEAR(c[0].overlap, 0.1 - 0.04 * std::sqrt(3.0), 1e-15);
  // Below the corner, beside two faces: the vertical edge x = y = 1.
  const auto edge = contacts(cube, Vec3(1.04, 1.04, 0.5), 0.1);
  ASSERT_EQ(edge.size(), 1u);
  EXPECT_EQ(cube.feature_kind(edge[0].feature), MeshFeatureKind::edge);
  // Nothing at all beyond reach.
  EXPECT_TRUE(contacts(cube, Vec3(1.06, 1.06, 1.06), 0.1).empty());
}

TEST(TriangleMesh, SphereInAConcaveCornerTouchesEachFaceOnce) {
  // A floor (z = 0, x in [0, 2]) meeting a wall (x = 0, z in [0, 2]) at a concave edge, y in [0, 1].
  const TriangleMesh l({{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {0, 1, 0}, {0, 0, 2}, {0, 1, 2}},
                       {{0, 1, 2}, {0, 2, 3}, {0, 3, 5}, {0, 5, 4}});
  EXPECT_TRUE(l.one_sided());
  expect_near(l.normal(2), Vec3::UnitX());
  const auto c = contacts(l, Vec3(0.08, 0.5, 0.07), 0.1);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c[0].feature, 0u);
  expect_near(c[0].normal, Vec3::UnitZ());
  EXPECT_NEAR(c[0].overlap, 0.03, 1e-15);
  EXPECT_EQ(c[1].feature, 2u);
  expect_near(c[1].normal, Vec3::UnitX());
  EXPECT_NEAR(c[1].overlap, 0.02, 1e-15);

  // The inside corner of a box (three faces meet): three face contacts.
  const TriangleMesh box({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}});
  const auto three = contacts(box, Vec3(0.05, 0.06, 0.07), 0.1);
  ASSERT_EQ(three.size(), 3u);
  for (const auto& k : three) EXPECT_EQ(box.feature_kind(k.feature), MeshFeatureKind::face);
}

TEST(TriangleMesh, OneSidedIgnoresTheBackAndTwoSidedRepelsBoth) {
  const TriangleMesh floor = floor_square();
  EXPECT_TRUE(contacts(floor, Vec3(1, 0.5, -0.05), 0.1).empty());
  // The rim from below: nothing either; from above beside the rim: an edge contact.
  EXPECT_TRUE(contacts(floor, Vec3(2.05, 1, -0.05), 0.1).empty());
  const auto rim = contacts(floor, Vec3(2.05, 1, 0.05), 0.1);
  ASSERT_EQ(rim.size(), 1u);
  expect_near(rim[0].normal, Vec3(1, 0, 1).normalized());

  // One triangle flipped: orientation inconsistent, so the mesh becomes two-sided.
  const TriangleMesh mixed({{0, 0, 0}, {2, 0, 0}, {2, 2, 0}, {0, 2, 0}}, {{0, 1, 2}, {0, 3, 2}});
  EXPECT_FALSE(mixed.one_sided());
  EXPECT_EQ(mixed.facet(1), 0u);  // still one flat facet
  const auto below = contacts(mixed, Vec3(1.5, 0.5, -0.06), 0.1);
  ASSERT_EQ(below.size(), 1u);
  expect_near(below[0].normal, -Vec3::UnitZ());
  EXPECT_NEAR(below[0].overlap, 0.04, 1e-15);
  const auto above = contacts(mixed, Vec3(0.5, 1.5, 0.06), 0.1);
  ASSERT_EQ(above.size(), 1u);
  expect_near(above[0].normal, Vec3::UnitZ());
}

TEST(TriangleMesh, NearlyCoplanarTrianglesFormOneFacetAndBentOnesDoNot) {
  // Two triangles hinged on the edge (0, 0, 0)-(0, 1, 0), the second tilted by `angle`.
  auto hinge = [](Real angle) {
    return TriangleMesh({{0, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {std::cos(angle), 0, std::sin(angle)}},
                        {{0, 1, 2}, {0, 3, 1}});
  };
  const TriangleMesh flat = hinge(1e-6);
  ASSERT_TRUE(flat.one_sided());
  EXPECT_EQ(flat.facet(1), 0u);
  const auto on_flat = contacts(flat, Vec3(1e-4, 0.5, 0.05), 0.1);
  ASSERT_EQ(on_flat.size(), 1u);  // the hinge is no feature: one face contact
  EXPECT_EQ(on_flat[0].feature, 0u);
  const TriangleMesh bent = hinge(-0.1);  // a convex fold
  EXPECT_EQ(bent.facet(1), 1u);
  const auto on_fold = contacts(bent, Vec3(0.002, 0.5, 0.05), 0.1);
  ASSERT_EQ(on_fold.size(), 1u);  // beyond both faces' reach: the fold's edge
  EXPECT_EQ(bent.feature_kind(on_fold[0].feature), MeshFeatureKind::edge);
  const TriangleMesh valley = hinge(0.1);  // a concave fold: both faces
  const auto in_valley = contacts(valley, Vec3(-0.002, 0.5, 0.05), 0.1);
  ASSERT_EQ(in_valley.size(), 2u);
  EXPECT_EQ(in_valley[0].feature, 0u);
  EXPECT_EQ(in_valley[1].feature, 1u);
}

TEST(TriangleMesh, TiltedTriangleMatchesAnalyticGeometry) {
  const Vec3 a(0.3, -0.2, 0.1), b(1.7, 0.4, -0.3), c(0.1, 1.5, 0.8);
  const TriangleMesh m({a, b, c}, {{0, 1, 2}});
  const Vec3 n = (b - a).cross(c - a).normalized();
  const Vec3 foot = (a + b + c) / 3;
  const auto face = contacts(m, foot + 0.07 * n, 0.1);
  ASSERT_EQ(face.size(), 1u);
  expect_near(face[0].normal, n);
  EXPECT_NEAR(face[0].overlap, 0.03, 1e-14);
  expect_near(face[0].point, foot);
  // Beyond edge a-b, out of the plane: the edge, normal from the nearest edge point.
  const Vec3 mid = 0.5 * (a + b);
  const Vec3 out = (b - a).cross(n).normalized();  // in-plane, away from c
  ASSERT_LT(out.dot(c - a), 0);
  const Vec3 x = mid + 0.04 * out + 0.03 * n;
  const auto edge = contacts(m, x, 0.1);
  ASSERT_EQ(edge.size(), 1u);
  EXPECT_EQ(edge[0].feature, 1u + 0u);  // edge (0, 1) is the first edge
  expect_near(edge[0].point, mid, 1e-14);
  EXPECT_NEAR(edge[0].overlap, 0.05, 1e-14);
}

TEST(TriangleMesh, NonFiniteOrFarCentresTouchNothing) {
  const TriangleMesh cube = unit_cube();
  EXPECT_TRUE(contacts(cube, Vec3(std::nan(""), 0.5, 0.5), 0.1).empty());
  EXPECT_TRUE(contacts(cube, Vec3(1e300, 0.5, 0.5), 0.1).empty());
  EXPECT_TRUE(contacts(cube, Vec3(0.5, 0.5, 1.05), 0).empty());
  EXPECT_THROW(TriangleMesh({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}, {{0, 1, 2}}), std::invalid_argument);
  EXPECT_THROW(TriangleMesh({{0, 0, 0}, {1, 0, 0}}, {{0, 1, 2}}), std::invalid_argument);
  EXPECT_THROW(TriangleMesh({}, {}), std::invalid_argument);
}

/// A wavy height field z = f(x, y) on an n x n grid over [0, 1]^2: convex and concave edges, facets
/// of one triangle each, and a few flat patches.
TriangleMesh wavy(int n, Real cell_size = 0) {
  std::vector<Vec3> p;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const Real x = Real(i) / n, y = Real(j) / n;
      const Real z = (i < n / 4 && j < n / 4) ? 0 : 0.05 * std::sin(9 * x) * std::cos(7 * y);
      p.emplace_back(x, y, z);
    }
  Triangles t;
  auto id = [&](int i, int j) { return std::uint32_t(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      t.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      t.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return TriangleMesh(p, t, cell_size);
}

TEST(TriangleMesh, GridLookupAgreesWithAllTriangles) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<Real> u(-0.1, 1.1), height(-0.12, 0.15), radius(0.002, 0.2);
  for (const Real cell : {0.0, 0.013, 0.3}) {
    const TriangleMesh m = wavy(24, cell);
    ASSERT_GT(m.cell_size(), 0);
    std::vector<MeshContact> grid, all;
    std::size_t touched = 0, multiple = 0;
    for (int k = 0; k < 4000; ++k) {
      const Vec3 x(u(rng), u(rng), height(rng));
      const Real r = radius(rng);
      m.query(x, r, grid);
      m.query_all_triangles(x, r, all);
      ASSERT_EQ(grid.size(), all.size()) << k;
      for (std::size_t q = 0; q < grid.size(); ++q) {
        EXPECT_EQ(grid[q].feature, all[q].feature);
        EXPECT_EQ(grid[q].normal, all[q].normal);
        EXPECT_EQ(grid[q].overlap, all[q].overlap);
        EXPECT_EQ(grid[q].point, all[q].point);
        EXPECT_GT(grid[q].overlap, 0);
        EXPECT_NEAR(grid[q].normal.norm(), 1, 1e-14);
        if (q > 0) {
          EXPECT_LT(grid[q - 1].feature, grid[q].feature);
        }
      }
      touched += grid.empty() ? 0 : 1;
      multiple += grid.size() > 1 ? 1 : 0;
    }
    EXPECT_GT(touched, 1000u);  // the test exercises contacts, several at once too
    EXPECT_GT(multiple, 100u);
  }
}

TEST(TriangleMesh, ContactIsContinuousAcrossFeatures) {
  // A sphere sliding over the wavy surface at a fixed height: every touched point's overlap equals
  // r minus the distance from the centre to the nearest point of the mesh (sampled densely).
  const TriangleMesh m = wavy(12);
  const Real r = 0.08;
  std::vector<MeshContact> c;
  for (int k = 0; k <= 200; ++k) {
    const Vec3 x(0.1 + 0.8 * k / 200.0, 0.37, 0.09);
    m.query(x, r, c);
    Real nearest = std::numeric_limits<Real>::infinity();
    for (const auto& t : m.triangles()) {
      for (int a = 0; a <= 40; ++a)
        for (int b = 0; a + b <= 40; ++b) {
          const Vec3 p = m.vertices()[t[0]] + (a / 40.0) * (m.vertices()[t[1]] - m.vertices()[t[0]]) +
                         (b / 40.0) * (m.vertices()[t[2]] - m.vertices()[t[0]]);
          nearest = std::min(nearest, (x - p).norm());
        }
    }
    Real deepest = 0;
    for (const auto& q : c) deepest = std::max(deepest, q.overlap);
    EXPECT_NEAR(deepest, std::max<Real>(0, r - nearest), 2e-4) << k;
  }
}

}  // namespace
}  // namespace dem
