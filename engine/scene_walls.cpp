// Scene section [[walls]]: planes, boxes, cylinders, prisms and meshes (their STL files read here).
#include "engine/scene_sections.h"

#include <filesystem>
#include <memory>
#include <stdexcept>

#include "engine/stl_reader.h"
#include "engine/triangle_mesh.h"
#include "engine/walls.h"

namespace dem::loader {

void read_walls(TableReader& top, Scene& scene, const std::string& base_dir) {
  const auto tables = top.tables("walls");
  if (tables.size() > max_walls)
    top.fail("walls", "at most " + std::to_string(max_walls) + " walls, not " + std::to_string(tables.size()));
  for (std::size_t i = 0; i < tables.size(); ++i) {
    TableReader r(*tables[i], indexed("walls", i), top.file());
    WallConfig w;
    w.name = r.string("name", "wall" + std::to_string(i));
    const std::size_t kind = r.choice("type", {"plane", "box", "cylinder", "prism", "mesh"}, 99);
    if (kind == 99) r.fail("type", "is required: one of plane, box, cylinder, prism, mesh");
    w.kind = static_cast<WallKind>(kind);
    w.material = read_material_name(r, scene, "material");
    w.point = r.vec3("point", Vec3::Zero());
    if (w.kind == WallKind::plane) {
      w.normal = r.vec3("normal", Vec3::UnitZ());
      if (w.normal.norm() == 0) r.fail("normal", "must be a non-zero vector");
    } else if (w.kind == WallKind::box) {
      w.half_extents = r.vec3("half_extents", Vec3::Ones());
      if (!(w.half_extents.minCoeff() > 0)) r.fail("half_extents", "all three half edge lengths must be > 0");
      w.inside = r.boolean("inside", true);
    } else if (w.kind == WallKind::cylinder) {
      w.axis = r.vec3("axis", Vec3::UnitZ());
      if (w.axis.norm() == 0) r.fail("axis", "must be a non-zero vector");
      w.radius = r.required_positive("radius");
      if (r.has("length")) w.length = r.positive("length", 1);
    } else if (w.kind == WallKind::mesh) {
      w.scale = r.positive("scale", 1);
      const std::string name = r.string("file", "");
      if (name.empty()) r.fail("file", "is required: an STL file (binary or ASCII), relative to the scene file");
      const std::filesystem::path path = std::filesystem::path(base_dir) / name;
      if (!std::filesystem::exists(path)) r.fail("file", "file not found: " + path.string());
      w.file = path.string();
      try {
        w.mesh = std::make_shared<const TriangleMesh>(read_stl_mesh(w.file, w.scale));
      } catch (const InputError& e) {
        r.fail("file", std::string("not a valid STL file: ") + e.what());
      } catch (const std::invalid_argument& e) {
        r.fail("file", std::string("not a valid STL file: ") + w.file + ": " + e.what());
      }
      if (w.mesh->feature_count() >= max_wall_features)
        r.fail("file", "the mesh has " + std::to_string(w.mesh->feature_count()) + " faces, edges and vertices; at most " +
                           std::to_string(max_wall_features - 1) + " fit a contact key");
    } else {
      w.axis = r.vec3("axis", Vec3::UnitZ());
      if (w.axis.norm() == 0) r.fail("axis", "must be a non-zero vector");
      if (r.has("length")) w.length = r.positive("length", 1);
      if (!r.has("profile")) r.fail("profile", "is required: the corners of the cross-section [[x, y, z], ...]");
      w.profile = r.vec3_list("profile");
      try {
        Walls::check_prism(w);
      } catch (const std::invalid_argument& e) {
        r.fail("profile", e.what());
      }
    }
    w.velocity = r.vec3("velocity", Vec3::Zero());
    w.angular_velocity = r.vec3("angular_velocity", Vec3::Zero());
    if (r.has("rotation_center")) {
      w.rotation_center = r.vec3("rotation_center", Vec3::Zero());
      w.use_rotation_center = true;
    }
    w.ramp_time = r.non_negative("ramp_time", 0);
    r.finish();
    scene.world.walls.push_back(w);
  }
}

}  // namespace dem::loader
