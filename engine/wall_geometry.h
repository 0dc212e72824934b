#pragma once
// Display geometry of the walls: triangles for the walls file of VTK output (write_walls_vtp), infinite
// walls given a finite extent. Not used by the physics.
#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace dem {

/// Triangulated walls for display. `wall_index[k]` is the wall of triangle k.
struct WallGeometry {
  std::vector<Eigen::Vector3d> points;                   // [m]
  std::vector<std::array<std::uint32_t, 3>> triangles;   // indices into points, counterclockwise
  std::vector<std::uint32_t> wall_index;                 // one per triangle
};

/// Appends `part` to `into`, shifting its point indices.
void append_wall_geometry(WallGeometry& into, const WallGeometry& part);

/// A square of half side `half_size` [m] centred on `point`, in the plane of normal `normal`; 2 triangles
/// facing along `normal` (the particles' side).
WallGeometry plane_geometry(const Eigen::Vector3d& point, const Eigen::Vector3d& normal, double half_size,
                            std::uint32_t wall = 0);
/// A box: `center`, `half_extents` [m] along its own axes, turned by the proper rotation `rotation`
/// (the box axes are its columns); 8 points, 12 triangles facing outwards.
WallGeometry box_geometry(const Eigen::Vector3d& center, const Eigen::Vector3d& half_extents,
                          const Eigen::Matrix3d& rotation, std::uint32_t wall = 0);
/// The open side surface of a cylinder of `radius` [m] and finite `length` [m] centred on `point`
/// along `axis`; `segments` (>= 3) quads, 2 triangles each, facing the axis (the particles' side).
WallGeometry cylinder_geometry(const Eigen::Vector3d& point, const Eigen::Vector3d& axis, double radius,
                               double length, int segments = 64, std::uint32_t wall = 0);

/// A solid prism: the convex cross-section `corners` [m] (in order around it, in the plane through the
/// prism's centre) extruded by `length` [m] along `axis`, centred; side quads and two fan-capped ends.
WallGeometry prism_geometry(const std::vector<Eigen::Vector3d>& corners, const Eigen::Vector3d& axis, double length,
                            std::uint32_t wall = 0);

}  // namespace dem
