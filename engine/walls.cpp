#include "engine/walls.h"

#include <cmath>
#include <stdexcept>

namespace dem {

Walls::Walls(const std::vector<WallConfig>& walls, const MaterialTable& materials) : config_(walls) {
  for (auto& w : config_) {
    if (!w.use_rotation_center) w.rotation_center = w.point;
    if (w.kind == WallKind::plane) w.normal.normalize();
    if (w.kind == WallKind::cylinder) w.axis.normalize();
    const int m = materials.find(w.material);
    if (m < 0) throw std::invalid_argument("wall '" + w.name + "' names an unknown material '" + w.material + "'");
    material_.push_back(static_cast<std::uint16_t>(m));
  }
  pose_.resize(config_.size());
  set_time(0);
}

std::uint32_t Walls::feature_count(std::size_t w) const {
  const WallConfig& c = config_[w];
  return c.kind == WallKind::box && c.inside ? 6 : 1;
}

void Walls::set_time(Real t) {
  for (std::size_t w = 0; w < config_.size(); ++w) {
    const WallConfig& c = config_[w];
    Pose& p = pose_[w];
    const Real angle = c.angular_velocity.norm() * t;
    p.rotation = angle > 0 ? Eigen::AngleAxisd(angle, c.angular_velocity.normalized()).toRotationMatrix()
                           : Eigen::Matrix3d::Identity();
    p.center = c.rotation_center + c.velocity * t;
    p.point = p.center + p.rotation * (c.point - c.rotation_center);
    p.direction = p.rotation * (c.kind == WallKind::plane ? c.normal : c.axis);
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
  }
  return false;
}

std::uint32_t Walls::touching_features(std::size_t w, const Vec3& x, Real r, std::uint32_t* features) const {
  const WallConfig& c = config_[w];
  std::uint32_t count = 0;
  if (c.kind == WallKind::box && c.inside) {
    // Six faces from one transform; the same expressions as touch() so the answers agree exactly.
    const Vec3 local = pose_[w].rotation.transpose() * (x - pose_[w].point);
    for (std::uint32_t f = 0; f < 6; ++f) {
      const int axis = static_cast<int>(f / 2);
      const Real side = (f % 2 == 0) ? -1 : 1;
      if (r - (c.half_extents[axis] - side * local[axis]) > 0) features[count++] = f;
    }
    return count;
  }
  WallTouch t;
  if (touch(w, 0, x, r, t)) features[count++] = 0;
  return count;
}

Vec3 Walls::velocity_at(std::size_t w, const Vec3& x) const {
  const WallConfig& c = config_[w];
  return c.velocity + c.angular_velocity.cross(x - pose_[w].center);
}

}  // namespace dem
