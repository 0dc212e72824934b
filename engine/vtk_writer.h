#pragma once
// VTK result files for ParaView: particle snapshots, the contact network and the walls as VTK XML
// PolyData (.vtp), and the .pvd collections that index them by time.
//
// Format: binary by default (every array in one appended raw block, little-endian, UInt64 byte-count
// headers), or ASCII (numbers as text, doubles with 17 significant digits so they read back
// bit-exactly). Every file is written whole and atomically (write_file_atomically). Errors throw
// (std::runtime_error for I/O, std::invalid_argument for inconsistent arrays). Never called inside a step.
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "engine/wall_geometry.h"

namespace dem {

enum class VtkFormat { binary, ascii };

/// "binary" or "ascii".
const char* vtk_format_name(VtkFormat format);

/// Particles at one time, in output order (usually ParticleId order). All arrays have the size of `id`,
/// except the optional ones, which may be empty (written as zeros, so every snapshot has the same arrays).
struct ParticleSnapshot {
  std::vector<std::uint32_t> id;
  std::vector<Eigen::Vector3d> position;          // [m]
  std::vector<Eigen::Vector3d> velocity;          // [m/s]
  std::vector<Eigen::Vector3d> angular_velocity;  // [rad/s]; optional
  std::vector<double> radius;                     // [m]
  std::vector<std::int32_t> level;                // step = dt_base * 2^level; optional
  std::vector<Eigen::Vector3d> force;             // sum of the contact forces, last evaluation [N]; optional
  std::vector<Eigen::Vector3d> torque;            // sum of the contact torques [N m]; optional
  std::vector<std::uint16_t> material;            // index into material_names; optional
  std::vector<std::uint32_t> coordination;        // touching contacts, pairs and walls; optional
  std::vector<std::string> material_names;        // FieldData `material_names` when not empty
};

/// Writes `snapshot` as a VTK XML PolyData file: one point and one vertex cell per particle, PointData
/// `id` (UInt32), `radius` (Float64), `velocity`, `angular_velocity` (Float64 x3), `level` (Int32),
/// `force`, `torque` (Float64 x3), `material` (UInt16), `coordination` (UInt32), and the FieldData
/// String array `material_names` (the name of material index k is its entry k). Atomic. Throws
/// std::invalid_argument on inconsistent array sizes.
void write_particles_vtp(const std::filesystem::path& path, const ParticleSnapshot& snapshot,
                         VtkFormat format = VtkFormat::binary);

/// The contact network at one time: one line per touching contact. A pair contact runs between the two
/// centres (`id_a` < `id_b`, `wall` -1); a wall contact runs from the particle's centre to its contact
/// point on the wall (`id_b` -1, `wall` the wall's index). Forces act on particle `id_a`: the pair
/// partner or the wall gets the negative.
struct ContactSnapshot {
  std::vector<Eigen::Vector3d> from, to;      // line ends [m]
  std::vector<std::int64_t> id_a, id_b;       // particle ids; id_b -1 for a wall contact
  std::vector<std::int32_t> wall;             // wall index, -1 for a pair contact
  std::vector<double> normal_force;           // along the normal from b (or the wall) to a; > 0 pushes apart [N]
  std::vector<Eigen::Vector3d> normal_force_vector;      // [N]
  std::vector<Eigen::Vector3d> tangential_force_vector;  // the rest of the contact force [N]
  std::vector<double> overlap;                // [m]
  std::size_t size() const { return id_a.size(); }
};

/// Writes `contacts` as a VTK XML PolyData file: two points per contact (its line's ends, in order), one
/// line cell per contact, CellData `id_a`, `id_b` (Int64), `wall` (Int32), `normal_force`, `overlap`
/// (Float64), `normal_force_vector`, `tangential_force_vector` (Float64 x3). Atomic. Throws
/// std::invalid_argument on inconsistent array sizes.
void write_contacts_vtp(const std::filesystem::path& path, const ContactSnapshot& contacts,
                        VtkFormat format = VtkFormat::binary);

/// Writes the triangles as Polys with a CellData `wall` (UInt32) array. Atomic. Throws
/// std::invalid_argument if an index is out of range or `wall_index` does not match `triangles`.
void write_walls_vtp(const std::filesystem::path& path, const WallGeometry& geometry,
                     VtkFormat format = VtkFormat::binary);

/// A ParaView collection (`.pvd`) listing snapshot files with their times; the whole file is rewritten
/// atomically on each change, so it is always valid. Opening an existing index keeps its entries
/// (resume); call truncate_after with the checkpoint's time to drop later ones.
class PvdIndex {
 public:
  /// Reads the entries of an existing index written by this class; throws std::runtime_error if the
  /// file exists but is not one.
  explicit PvdIndex(std::filesystem::path path);

  /// Adds a snapshot: `time` [s] finite and greater than the last entry's, `relative_file` relative to the
  /// .pvd's folder. Rewrites the file. Throws std::invalid_argument otherwise.
  void add(double time, const std::string& relative_file);
  /// Keeps the entries with time <= `time` [s] and rewrites the file.
  void truncate_after(double time);

  struct Entry {
    double time;  // [s]
    std::string file;
  };
  const std::vector<Entry>& entries() const { return entries_; }
  const std::filesystem::path& path() const { return path_; }

 private:
  void write() const;

  std::filesystem::path path_;
  std::vector<Entry> entries_;
};

}  // namespace dem
