#include "engine/walls.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace dem {

namespace {

using Vec2 = Eigen::Vector2d;

Real cross2(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

}  // namespace

Real ramp_distance(Real t, Real ramp) { return ramp > 0 && t < ramp ? t * t / (2 * ramp) : t - 0.5 * std::max(ramp, Real(0)); }
Real ramp_rate(Real t, Real ramp) { return ramp > 0 && t < ramp ? t / ramp : 1; }

namespace {

/// True when wall c's turning leaves its surface where it is: it does not turn, or it is a plane
/// turning about its normal, or a cylinder turning about its own axis (the rotation centre on it).
/// Only its translation moves such a wall.
bool turns_in_place(const WallConfig& c) {
  if (c.angular_velocity.norm() == 0) return true;
  if (c.kind == WallKind::plane) return c.angular_velocity.cross(c.normal).norm() == 0;
  if (c.kind == WallKind::cylinder)
    return c.angular_velocity.cross(c.axis).norm() == 0 && (c.rotation_center - c.point).cross(c.axis).norm() == 0;
  return false;
}

/// Walls::filtered for wall c.
bool filtered_by_wall_lists(const WallConfig& c) {
  switch (c.kind) {
    case WallKind::prism:
      return true;
    case WallKind::mesh:
      return false;
    case WallKind::box:
      return c.angular_velocity.norm() == 0;
    default:
      return turns_in_place(c);
  }
}

}  // namespace

Walls::Walls(const std::vector<WallConfig>& walls, const MaterialTable& materials) : config_(walls) {
  for (auto& w : config_) {
    if (!w.use_rotation_center) w.rotation_center = w.point;
    if (w.kind == WallKind::plane) w.normal.normalize();
    if (w.kind == WallKind::cylinder || w.kind == WallKind::prism) w.axis.normalize();
    if (w.kind == WallKind::mesh) {
      // The core reads no files: the loader (or a program embedding the engine) builds the mesh.
      if (!w.mesh) throw std::invalid_argument("mesh wall '" + w.name + "' needs a mesh");
      if (w.mesh->feature_count() >= max_wall_features)
        throw std::invalid_argument("mesh wall '" + w.name + "' has " + std::to_string(w.mesh->feature_count()) +
                                    " faces, edges and vertices; at most " + std::to_string(max_wall_features - 1) +
                                    " fit a contact key");
    }
    const int m = materials.find(w.material);
    if (m < 0) throw std::invalid_argument("wall '" + w.name + "' names an unknown material '" + w.material + "'");
    material_.push_back(static_cast<std::uint16_t>(m));
    prism_.push_back(w.kind == WallKind::prism ? make_prism(w) : PrismShape{});
    filtered_.push_back(filtered_by_wall_lists(w) ? 1 : 0);
  }
  if (config_.size() > max_walls)
    throw std::invalid_argument("at most " + std::to_string(max_walls) + " walls fit a contact key, not " +
                                std::to_string(config_.size()));
  for (std::size_t w = 0; w < config_.size(); ++w) {
    const WallConfig& c = config_[w];
    const WallConfig* before = w > 0 ? &config_[w - 1] : nullptr;
    turns_with_previous_.push_back(before && before->angular_velocity == c.angular_velocity &&
                                   before->ramp_time == c.ramp_time);
    travel_rate_.push_back(c.velocity.norm() + c.angular_velocity.norm() * prism_[w].reach);
    // A plane or cylinder turning in place (turns_in_place): its posed normal or axis is the configured
    // one up to the rounding of the rotation matrix, which moves the computed surface by a few ulps of
    // the coordinates; one nanometre per metre of its extent bounds that with room to spare (at worst,
    // with a margin below it, the lists are rebuilt at every step: slower, never wrong).
    Real rounding = 0;
    if (c.kind != WallKind::prism && c.angular_velocity.norm() != 0) {
      const Real length = std::isfinite(c.length) ? c.length : 0;
      rounding = 1e-9 * (1 + c.point.norm() + c.rotation_center.norm() + c.radius + length);
    }
    travel_rounding_.push_back(rounding);
  }
  pose_.resize(config_.size());
  set_time(0);
}

Walls::PrismShape Walls::make_prism(const WallConfig& w) {
  auto fail = [&](const std::string& why) { throw std::invalid_argument("prism wall '" + w.name + "': " + why); };
  if (!(w.length > 0)) fail("length must be > 0");
  PrismShape shape;
  shape.u = w.axis.unitOrthogonal();
  shape.v = w.axis.cross(shape.u);
  shape.half_length = 0.5 * w.length;
  for (const Vec3& c : w.profile) shape.corner.emplace_back((c - w.point).dot(shape.u), (c - w.point).dot(shape.v));
  const std::size_t n = shape.corner.size();
  if (n < 3) fail("the profile needs at least 3 corners");
  Real area = 0;
  for (std::size_t i = 0; i < n; ++i) area += cross2(shape.corner[i], shape.corner[(i + 1) % n]);
  if (!(std::abs(area) > 0)) fail("the profile encloses no area");
  if (area < 0) std::reverse(shape.corner.begin(), shape.corner.end());
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2 edge = shape.corner[(i + 1) % n] - shape.corner[i];
    if (!(edge.norm() > 0)) fail("two consecutive profile corners coincide");
    if (cross2(edge, shape.corner[(i + 2) % n] - shape.corner[(i + 1) % n]) <= 0)
      fail("the profile must be strictly convex, its corners in order around it");
    shape.normal.emplace_back(Vec2(edge.y(), -edge.x()).normalized());
  }
  // Left turns at every corner also pass a star (a pentagram): a convex polygon also has every
  // corner on the inner side of every edge.
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t k = 0; k < n; ++k)
      if (shape.normal[i].dot(shape.corner[k] - shape.corner[i]) > 1e-12 * std::sqrt(std::abs(area)))
        fail("the profile must be a convex polygon, its corners in order around it (it crosses itself)");
  for (const Vec2& c : shape.corner) shape.middle += c / static_cast<Real>(n);
  for (const Vec2& c : shape.corner) shape.bound = std::max(shape.bound, (c - shape.middle).norm());
  // The farthest point of a convex solid from a line (the rotation axis) is one of its corners.
  const Vec3 spin_axis = w.angular_velocity.norm() > 0 ? Vec3(w.angular_velocity.normalized()) : Vec3::Zero();
  for (const Vec2& c : shape.corner)
    for (const Real end : {-shape.half_length, shape.half_length}) {
      const Vec3 arm = w.point + c.x() * shape.u + c.y() * shape.v + end * w.axis - w.rotation_center;
      shape.reach = std::max(shape.reach, (arm - arm.dot(spin_axis) * spin_axis).norm());
    }
  return shape;
}

std::uint32_t Walls::feature_count(std::size_t w) const {
  const WallConfig& c = config_[w];
  if (c.kind == WallKind::mesh) return static_cast<std::uint32_t>(c.mesh->feature_count());
  return c.kind == WallKind::box && c.inside ? 6 : 1;
}

const std::vector<MeshContact>& Walls::mesh_contacts(std::size_t w, const Vec3& x, Real r) const {
  thread_local std::vector<MeshContact> contacts;
  const Pose& p = pose_[w];
  config_[w].mesh->query(p.rotation.transpose() * (x - p.point), r, contacts);  // into the t = 0 frame
  return contacts;
}

void Walls::set_time(Real t) {
  time_ = t;
  Real s = 0, rate = 0;  // the ramp's distance factor and rate, shared by walls that turn together
  for (std::size_t w = 0; w < config_.size(); ++w) {
    const WallConfig& c = config_[w];
    Pose& p = pose_[w];
    // A mill's walls turn together: a wall with the previous one's spin and ramp takes its rotation.
    if (turns_with_previous_[w]) {
      p.rotation = pose_[w - 1].rotation;
    } else {
      s = ramp_distance(t, c.ramp_time);
      rate = ramp_rate(t, c.ramp_time);
      const Real angle = c.angular_velocity.norm() * s;
      p.rotation = angle != 0 ? Eigen::AngleAxisd(angle, c.angular_velocity.normalized()).toRotationMatrix()
                             : Eigen::Matrix3d::Identity();
    }
    p.center = c.rotation_center + c.velocity * s;
    p.point = p.center + p.rotation * (c.point - c.rotation_center);
    p.direction = p.rotation * (c.kind == WallKind::plane ? c.normal : c.axis);
    p.velocity = rate * c.velocity;
    p.angular_velocity = rate * c.angular_velocity;
  }
}

bool Walls::touch(std::size_t w, std::uint32_t f, const Vec3& x, Real r, WallTouch& out) const {
  const WallConfig& c = config_[w];
  const Pose& p = pose_[w];
  switch (c.kind) {
    case WallKind::plane: {
      const Real d = (x - p.point).dot(p.direction);
      out.overlap = r - d;
      out.normal = p.direction;
      return out.overlap > 0 && d > -r;  // a particle wholly behind the plane is not its business
    }
    case WallKind::box: {
      const Vec3 local = p.rotation.transpose() * (x - p.point);
      const Vec3& h = c.half_extents;
      if (c.inside) {
        const int axis = static_cast<int>(f / 2);
        const Real side = (f % 2 == 0) ? -1 : 1;  // face at local coordinate side * h
        const Real d = h[axis] - side * local[axis];
        out.overlap = r - d;
        out.normal = -side * p.rotation.col(axis);
        return out.overlap > 0;
      }
      const Vec3 nearest = local.cwiseMax(-h).cwiseMin(h);
      const Vec3 gap = local - nearest;
      const Real d = gap.norm();
      if (d > 0) {
        out.overlap = r - d;
        out.normal = p.rotation * (gap / d);
        return out.overlap > 0;
      }
      // Centre inside the block: push out through the nearest face.
      int axis = 0;
      Real depth = h[0] - std::abs(local[0]);
      for (int k = 1; k < 3; ++k) {
        const Real dk = h[k] - std::abs(local[k]);
        if (dk < depth) depth = dk, axis = k;
      }
      out.overlap = r + depth;
      out.normal = (local[axis] >= 0 ? 1.0 : -1.0) * p.rotation.col(axis);
      return true;
    }
    case WallKind::cylinder: {
      const Vec3 rel = x - p.point;
      const Real along = rel.dot(p.direction);
      if (std::abs(along) > 0.5 * c.length) return false;
      const Vec3 radial = rel - along * p.direction;
      const Real rho = radial.norm();
      out.overlap = r - (c.radius - rho);
      if (out.overlap <= 0 || rho == 0) return false;
      out.normal = -radial / rho;
      return true;
    }
    case WallKind::prism:
      return touch_prism(w, x, r, out);
    case WallKind::mesh: {
      const std::vector<MeshContact>& contacts = mesh_contacts(w, x, r);
      const auto it = std::lower_bound(contacts.begin(), contacts.end(), f,
                                       [](const MeshContact& m, std::uint32_t id) { return m.feature < id; });
      if (it == contacts.end() || it->feature != f) return false;
      out.overlap = it->overlap;
      out.normal = p.rotation * it->normal;
      return true;
    }
  }
  return false;
}

bool Walls::touch_prism(std::size_t w, const Vec3& x, Real r, WallTouch& out) const {
  const PrismShape& shape = prism_[w];
  const Pose& p = pose_[w];
  const Vec3 rel = p.rotation.transpose() * (x - p.point);  // in the t = 0 frame
  const Vec2 q(rel.dot(shape.u), rel.dot(shape.v));
  const Real along = rel.dot(config_[w].axis);
  // Most particles are nowhere near a lifter: one distance rules them out.
  if ((q - shape.middle).squaredNorm() > (r + shape.bound) * (r + shape.bound) || std::abs(along) > shape.half_length + r)
    return false;
  const std::size_t n = shape.corner.size();
  // Signed distance to each edge line: all <= 0 means q lies inside the cross-section.
  Real outmost = -std::numeric_limits<Real>::infinity();
  std::size_t outmost_edge = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Real d = shape.normal[i].dot(q - shape.corner[i]);
    if (d > outmost) outmost = d, outmost_edge = i;
  }
  const Real axial_depth = shape.half_length - std::abs(along);
  if (outmost <= 0 && axial_depth >= 0) {
    // Centre inside the solid: push out through the nearest side (the end faces included).
    Vec3 normal0;
    Real depth;
    if (axial_depth < -outmost) {
      depth = axial_depth;
      normal0 = (along >= 0 ? 1.0 : -1.0) * config_[w].axis;
    } else {
      depth = -outmost;
      normal0 = shape.normal[outmost_edge].x() * shape.u + shape.normal[outmost_edge].y() * shape.v;
    }
    out.overlap = r + depth;
    out.normal = p.rotation * normal0;
    return true;
  }
  Vec2 nearest = q;
  if (outmost > 0) {
    Real best = std::numeric_limits<Real>::infinity();
    for (std::size_t i = 0; i < n; ++i) {
      const Vec2 a = shape.corner[i], edge = shape.corner[(i + 1) % n] - a;
      const Real f = std::clamp((q - a).dot(edge) / edge.squaredNorm(), Real(0), Real(1));
      const Vec2 point = a + f * edge;
      const Real d2 = (q - point).squaredNorm();
      if (d2 < best) best = d2, nearest = point;
    }
  }
  const Real nearest_along = std::clamp(along, -shape.half_length, shape.half_length);
  const Vec3 gap = (q - nearest).x() * shape.u + (q - nearest).y() * shape.v + (along - nearest_along) * config_[w].axis;
  const Real d = gap.norm();
  out.overlap = r - d;
  if (out.overlap <= 0) return false;
  // A centre exactly on the surface has no gap direction: the outmost side's normal.
  const Vec3 normal0 = d > 0 ? Vec3(gap / d)
                             : Vec3(shape.normal[outmost_edge].x() * shape.u + shape.normal[outmost_edge].y() * shape.v);
  out.normal = p.rotation * normal0;
  return true;
}

bool Walls::may_touch(std::size_t w, const Vec3& x, Real r, Real margin) const {
  if (!filtered(w)) return true;
  const WallConfig& c = config_[w];
  const Pose& pose = pose_[w];
  const Real reach = r + margin;
  // touch()'s tests at radius r + margin (a sphere that touches at r touches at any larger radius):
  // within the margin of touching now.
  switch (c.kind) {
    case WallKind::plane: {
      const Real d = (x - pose.point).dot(pose.direction);
      return d < reach && d > -reach;
    }
    case WallKind::box: {
      const Vec3 local = pose.rotation.transpose() * (x - pose.point);
      const Vec3& h = c.half_extents;
      if (c.inside) return ((h - local.cwiseAbs()).array() < reach).any();
      return (local - local.cwiseMax(-h).cwiseMin(h)).norm() < reach;
    }
    case WallKind::cylinder: {
      const Vec3 rel = x - pose.point;
      const Real along = rel.dot(pose.direction);
      return std::abs(along) <= 0.5 * c.length + margin && (rel - along * pose.direction).norm() > c.radius - reach;
    }
    case WallKind::prism: {
      // touch_prism's first test, widened by the margin: a sphere that touches the prism is within
      // `bound` of its middle across the axis and within half its length of its middle along it.
      const PrismShape& shape = prism_[w];
      const Vec3 rel = pose.rotation.transpose() * (x - pose.point);
      const Vec2 q(rel.dot(shape.u), rel.dot(shape.v));
      return (q - shape.middle).squaredNorm() <= (reach + shape.bound) * (reach + shape.bound) &&
             std::abs(rel.dot(c.axis)) <= shape.half_length + reach;
    }
    case WallKind::mesh:
      break;
  }
  return true;
}

Real Walls::max_travel(std::size_t w, Real t0, Real t1) const {
  if (!filtered(w)) return 0;
  // A point at distance rho from the rotation axis moves by at most rho times the angle turned, the
  // centre by the translation; both are the configured rates times the ramp's distance factor. A
  // filtered wall other than a prism does not turn, or turns in place (no prism reach): its surface
  // travels with its centre.
  const WallConfig& c = config_[w];
  const Real distance = ramp_distance(t1, c.ramp_time) - ramp_distance(t0, c.ramp_time);
  return travel_rate_[w] * std::abs(distance) + travel_rounding_[w];
}

std::uint32_t Walls::touching_features(std::size_t w, const Vec3& x, Real r, std::uint32_t* features,
                                       WallTouch* touches, std::uint32_t room) const {
  const WallConfig& c = config_[w];
  const Pose& p = pose_[w];
  std::uint32_t count = 0;
  const auto found = [&](std::uint32_t f, const WallTouch& t) {
    if (count < room) features[count] = f, touches[count] = t;
    ++count;
  };
  if (c.kind == WallKind::box && c.inside) {
    // Six faces from one transform; the same expressions as touch() so the answers agree exactly.
    const Vec3 local = p.rotation.transpose() * (x - p.point);
    for (std::uint32_t f = 0; f < 6; ++f) {
      const int axis = static_cast<int>(f / 2);
      const Real side = (f % 2 == 0) ? -1 : 1;
      const Real overlap = r - (c.half_extents[axis] - side * local[axis]);
      if (!(overlap > 0)) continue;
      if (count < room) found(f, WallTouch{-side * p.rotation.col(axis), overlap});
      else ++count;  // counted only: no geometry to build
    }
    return count;
  }
  if (c.kind == WallKind::mesh) {
    const std::vector<MeshContact>& contacts = mesh_contacts(w, x, r);
    if (room == 0) return static_cast<std::uint32_t>(contacts.size());
    for (const MeshContact& m : contacts) found(m.feature, WallTouch{p.rotation * m.normal, m.overlap});
    return count;
  }
  WallTouch t;
  if (touch(w, 0, x, r, t)) found(0, t);
  return count;
}

std::uint32_t Walls::touching_features(std::size_t w, const Vec3& x, Real r, std::uint32_t* features) const {
  if (config_[w].kind == WallKind::mesh) {
    std::uint32_t count = 0;
    for (const MeshContact& m : mesh_contacts(w, x, r)) features[count++] = m.feature;
    return count;
  }
  WallTouch touches[6];
  return touching_features(w, x, r, features, touches, 6);
}

Vec3 Walls::velocity_at(std::size_t w, const Vec3& x) const {
  return pose_[w].velocity + pose_[w].angular_velocity.cross(x - pose_[w].center);
}

}  // namespace dem
