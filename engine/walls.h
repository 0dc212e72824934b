#pragma once
// Walls with prescribed motion: planes, finite boxes (container or solid), the inside of a
// cylinder, solid convex prisms (lifter bars) and triangle meshes (liners from STL files). A wall's geometry at time t is its t = 0 geometry
// translated by v s(t) and rotated by |Omega| s(t) about its rotation centre, s(t) the distance
// factor of its start-up ramp (config.h), exact in t with no accumulated drift. Walls have infinite mass.
// Threading: after set_time, all queries are const and safe from any thread.
#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Geometry>

#include "engine/config.h"
#include "engine/materials.h"
#include "engine/triangle_mesh.h"

namespace dem {

/// Geometry of one particle-wall contact: unit normal from the wall into the particle and overlap.
struct WallTouch {
  Vec3 normal;   // from the wall towards the particle centre
  Real overlap;  // delta > 0 in contact [m]
};

/// Start-up ramp (config.h): the distance factor s(t) (t^2 / 2T, then t - T/2) and its rate s'(t).
Real ramp_distance(Real t, Real ramp_time);
Real ramp_rate(Real t, Real ramp_time);

/// Resultant load of the particles on one wall.
struct WallLoad {
  Vec3 force = Vec3::Zero();   // [N]
  Vec3 torque = Vec3::Zero();  // about the wall's current rotation centre [N m]
};

class Walls {
 public:
  Walls() = default;
  /// Builds from the configs' data only: a mesh wall needs its `mesh` (the scene loader reads STL
  /// files into it; `file` is not opened here). Throws std::invalid_argument for a mesh wall without
  /// a mesh, more than max_walls walls or a mesh of max_wall_features features or more (types.h:
  /// they must fit a contact key).
  Walls(const std::vector<WallConfig>& walls, const MaterialTable& materials);

  /// Throws std::invalid_argument naming the problem when a prism's profile is not a convex polygon.
  static void check_prism(const WallConfig& w) { make_prism(w); }

  std::size_t count() const { return config_.size(); }
  const WallConfig& config(std::size_t w) const { return config_[w]; }
  std::uint16_t material(std::size_t w) const { return material_[w]; }
  /// Feature ids of wall w lie in [0, feature_count(w)): 6 faces inside a box, a mesh's faces, edges
  /// and vertices (triangle_mesh.h), else 1. Not a bound on the features touched at once: loop over
  /// touching_features, never over all ids (a mesh has thousands).
  std::uint32_t feature_count(std::size_t w) const;

  /// Moves every wall to its pose at time t [s].
  void set_time(Real t);
  /// The time of the current poses [s].
  Real time() const { return time_; }

  /// Contact of a sphere (centre x, radius r) with feature f of wall w; false if not touching.
  bool touch(std::size_t w, std::uint32_t f, const Vec3& x, Real r, WallTouch& out) const;
  /// Features of wall w a sphere touches, in ascending order, with the geometry touch() gives each:
  /// the first `room` of them are written to features[] and touches[]; returns how many there are
  /// (more than `room` when they do not fit; at most 6 for walls other than meshes). The same answers
  /// as touch() on each feature, bit for bit, with the geometry set up once. A feature touched at
  /// radius r is touched at any larger radius too (for a mesh: triangle_mesh.h's rules keep that).
  std::uint32_t touching_features(std::size_t w, const Vec3& x, Real r, std::uint32_t* features, WallTouch* touches,
                                  std::uint32_t room) const;
  /// The same features without their geometry, all of them (room for touching_count(w, x, r)).
  std::uint32_t touching_features(std::size_t w, const Vec3& x, Real r, std::uint32_t* features) const;
  /// How many features touching_features finds.
  std::uint32_t touching_count(std::size_t w, const Vec3& x, Real r) const {
    return touching_features(w, x, r, nullptr, nullptr, 0);
  }
  /// Whether the wall lists of a wall broadphase (wall_lists.h) filter wall w: prisms (lifter bars,
  /// many and small, so most particles are far from most of them), boxes that do not turn, and planes
  /// and cylinders whose turning leaves their surface in place (a container, a mill's shell and end
  /// walls: most particles are far from them). Meshes and other turning walls are tested always.
  bool filtered(std::size_t w) const { return filtered_[w] != 0; }
  /// For a filtered wall: false only when the sphere (centre x, radius r) is more than `margin` [m]
  /// clear of the wall's bound now, so no motion of the two that adds up to at most `margin` brings
  /// them into touch. True for every other kind.
  bool may_touch(std::size_t w, const Vec3& x, Real r, Real margin) const;
  /// Bound on how far any point of a filtered wall moves from time t0 to t1 >= t0 [m]: its
  /// translation plus its rotation's arc at the corner farthest from the axis (0 for other kinds).
  Real max_travel(std::size_t w, Real t0, Real t1) const;
  /// The mesh of a mesh wall (its t = 0 geometry relative to `point`), else null.
  const TriangleMesh* mesh(std::size_t w) const { return config_[w].mesh.get(); }

  /// Velocity of the wall's material at point p [m/s].
  Vec3 velocity_at(std::size_t w, const Vec3& p) const;
  /// Angular velocity now (the configured one scaled by the start-up ramp) [rad/s].
  const Vec3& angular_velocity(std::size_t w) const { return pose_[w].angular_velocity; }
  /// Current rotation centre (torques are reported about it).
  const Vec3& rotation_center(std::size_t w) const { return pose_[w].center; }
  /// Current pose: a point of the geometry (plane point, box centre, cylinder axis point).
  const Vec3& point(std::size_t w) const { return pose_[w].point; }
  const Eigen::Matrix3d& rotation(std::size_t w) const { return pose_[w].rotation; }

 private:
  struct Pose {
    Vec3 center;               // rotation centre now
    Vec3 point;                // the config's `point` now
    Eigen::Matrix3d rotation;  // rotation since t = 0
    Vec3 direction;            // plane normal or cylinder axis now
    Vec3 velocity;             // of the rotation centre now [m/s]
    Vec3 angular_velocity;     // now [rad/s]
  };
  /// A prism's cross-section in its own t = 0 frame: coordinates along u and v, axis = u x v.
  struct PrismShape {
    Vec3 u, v;
    std::vector<Eigen::Vector2d> corner;  // counter-clockwise about the axis
    std::vector<Eigen::Vector2d> normal;  // outward unit normal of edge corner[i] -> corner[i + 1]
    Real half_length = 0;
    Eigen::Vector2d middle = Eigen::Vector2d::Zero();  // mean of the corners
    Real bound = 0;  // largest distance of a corner from `middle`: beyond it plus r, no contact [m]
    Real reach = 0;  // largest distance of a corner from the wall's rotation axis [m]
  };
  static PrismShape make_prism(const WallConfig& w);
  bool touch_prism(std::size_t w, const Vec3& x, Real r, WallTouch& out) const;
  /// Contacts of the sphere with mesh wall w, in the mesh's frame (a thread-local list, valid until
  /// the calling thread's next call).
  const std::vector<MeshContact>& mesh_contacts(std::size_t w, const Vec3& x, Real r) const;

  std::vector<WallConfig> config_;
  std::vector<PrismShape> prism_;  // per wall; empty shape for other kinds
  std::vector<char> filtered_;     // per wall: filtered(w), fixed by its kind and motion
  // Per wall, fixed by its config: whether it turns and ramps as the wall before it (its pose takes
  // that wall's rotation and ramp), and for max_travel its speed at its farthest point per unit of
  // ramp distance and its rounding allowance [m].
  std::vector<char> turns_with_previous_;
  std::vector<Real> travel_rate_, travel_rounding_;
  std::vector<std::uint16_t> material_;
  std::vector<Pose> pose_;
  Real time_ = 0;
};

}  // namespace dem
