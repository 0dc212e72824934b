#include "engine/wall_geometry.h"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>

namespace dem {
namespace {

void check_finite_positive(double value, const char* what) {
  if (!std::isfinite(value) || value <= 0) {
    throw std::invalid_argument(std::string(what) + " must be finite and positive");
  }
}

Eigen::Vector3d unit_direction(const Eigen::Vector3d& v, const char* what) {
  const double norm = v.norm();
  if (!std::isfinite(norm) || norm == 0) {
    throw std::invalid_argument(std::string(what) + " must be a finite non-zero vector");
  }
  return v / norm;
}

}  // namespace

void append_wall_geometry(WallGeometry& into, const WallGeometry& part) {
  const auto offset = static_cast<std::uint32_t>(into.points.size());
  into.points.insert(into.points.end(), part.points.begin(), part.points.end());
  for (const auto& tri : part.triangles) into.triangles.push_back({tri[0] + offset, tri[1] + offset, tri[2] + offset});
  into.wall_index.insert(into.wall_index.end(), part.wall_index.begin(), part.wall_index.end());
}

WallGeometry plane_geometry(const Eigen::Vector3d& point, const Eigen::Vector3d& normal, double half_size,
                            std::uint32_t wall) {
  check_finite_positive(half_size, "plane_geometry: half_size");
  const Eigen::Vector3d n = unit_direction(normal, "plane_geometry: normal");
  // (u, v, n) right-handed, so the counterclockwise corners below face along n.
  const Eigen::Vector3d u = n.unitOrthogonal() * half_size;
  const Eigen::Vector3d v = n.cross(n.unitOrthogonal()) * half_size;
  WallGeometry g;
  g.points = {point - u - v, point + u - v, point + u + v, point - u + v};
  g.triangles = {{0, 1, 2}, {0, 2, 3}};
  g.wall_index = {wall, wall};
  return g;
}

WallGeometry box_geometry(const Eigen::Vector3d& center, const Eigen::Vector3d& half_extents,
                          const Eigen::Matrix3d& rotation, std::uint32_t wall) {
  for (int a = 0; a < 3; ++a) check_finite_positive(half_extents[a], "box_geometry: half_extents");
  if (!rotation.allFinite() || (rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).norm() > 1e-9 ||
      rotation.determinant() <= 0) {
    throw std::invalid_argument("box_geometry: rotation must be a proper rotation matrix (orthonormal, det +1)");
  }
  WallGeometry g;
  // Corner k has sign + along axis a when bit a of k is set.
  for (std::uint32_t k = 0; k < 8; ++k) {
    Eigen::Vector3d local;
    for (int a = 0; a < 3; ++a) local[a] = ((k >> a) & 1U) != 0 ? half_extents[a] : -half_extents[a];
    g.points.push_back(center + rotation * local);
  }
  // Face of axis a, side s: corners ordered (b, c) = (0,0), (1,0), (1,1), (0,1) with b, c the next axes in
  // cyclic order face along e_b x e_c = e_a; the side s = 0 is reversed to face along -e_a.
  for (std::uint32_t a = 0; a < 3; ++a) {
    const std::uint32_t b = (a + 1) % 3;
    const std::uint32_t c = (a + 2) % 3;
    for (std::uint32_t s = 0; s < 2; ++s) {
      const std::uint32_t base = s << a;
      const std::array<std::uint32_t, 4> quad = {base, base | (1U << b), base | (1U << b) | (1U << c),
                                                 base | (1U << c)};
      if (s == 1) {
        g.triangles.push_back({quad[0], quad[1], quad[2]});
        g.triangles.push_back({quad[0], quad[2], quad[3]});
      } else {
        g.triangles.push_back({quad[0], quad[2], quad[1]});
        g.triangles.push_back({quad[0], quad[3], quad[2]});
      }
    }
  }
  g.wall_index.assign(g.triangles.size(), wall);
  return g;
}

WallGeometry prism_geometry(const std::vector<Eigen::Vector3d>& corners, const Eigen::Vector3d& axis, double length,
                            std::uint32_t wall) {
  check_finite_positive(length, "prism_geometry: length (give a finite display length)");
  if (corners.size() < 3) throw std::invalid_argument("prism_geometry: at least 3 corners");
  const Eigen::Vector3d half = 0.5 * length * unit_direction(axis, "prism_geometry: axis");
  const auto n = static_cast<std::uint32_t>(corners.size());
  WallGeometry g;
  for (const auto& c : corners) g.points.push_back(c - half);  // points 0 .. n-1: the back end
  for (const auto& c : corners) g.points.push_back(c + half);  // n .. 2n-1: the front end
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint32_t j = (i + 1) % n;
    g.triangles.push_back({i, j, n + j});
    g.triangles.push_back({i, n + j, n + i});
  }
  for (std::uint32_t i = 1; i + 1 < n; ++i) {
    g.triangles.push_back({0, i + 1, i});
    g.triangles.push_back({n, n + i, n + i + 1});
  }
  g.wall_index.assign(g.triangles.size(), wall);
  return g;
}

WallGeometry cylinder_geometry(const Eigen::Vector3d& point, const Eigen::Vector3d& axis, double radius,
                               double length, int segments, std::uint32_t wall) {
  check_finite_positive(radius, "cylinder_geometry: radius");
  check_finite_positive(length, "cylinder_geometry: length (give a finite display length)");
  if (segments < 3) throw std::invalid_argument("cylinder_geometry: segments must be at least 3");
  const Eigen::Vector3d a = unit_direction(axis, "cylinder_geometry: axis");
  const Eigen::Vector3d u = a.unitOrthogonal();
  const Eigen::Vector3d v = a.cross(u);  // (u, v, a) right-handed
  const Eigen::Vector3d half = a * (0.5 * length);
  const auto m = static_cast<std::uint32_t>(segments);
  WallGeometry g;
  g.points.reserve(2 * m);
  for (std::uint32_t i = 0; i < m; ++i) {
    const double angle = 2 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(m);
    const Eigen::Vector3d radial = (std::cos(angle) * u + std::sin(angle) * v) * radius;
    g.points.push_back(point - half + radial);  // 2i: bottom
    g.points.push_back(point + half + radial);  // 2i + 1: top
  }
  // Bottom b_i, top t_i; (b_i, t_i, t_{i+1}) and (b_i, t_{i+1}, b_{i+1}) face the axis.
  for (std::uint32_t i = 0; i < m; ++i) {
    const std::uint32_t j = (i + 1) % m;
    g.triangles.push_back({2 * i, 2 * i + 1, 2 * j + 1});
    g.triangles.push_back({2 * i, 2 * j + 1, 2 * j});
  }
  g.wall_index.assign(g.triangles.size(), wall);
  return g;
}

}  // namespace dem
