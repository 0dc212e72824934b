// Scene sections [[particles]], [[particle_files]] and [[generators]].
#include "engine/scene_sections.h"

#include <filesystem>

#include "engine/particle_csv.h"
#include "engine/particle_generator.h"

namespace dem::loader {

/// The `size` table of a generator or a mill charge: the radius distribution.
void read_size(TableReader& r, GeneratorConfig& g) {
  const toml::table* size = r.table("size");
  if (!size) r.fail("size", "is required: { distribution = \"mono\", radius = ... } (or uniform, normal, lognormal)");
  {
    TableReader s(*size, r.field("size"), r.file());
    g.distribution = static_cast<SizeDistribution>(s.choice("distribution", {"mono", "uniform", "normal", "lognormal"}, 0));
    switch (g.distribution) {
      case SizeDistribution::mono:
        g.r_min = g.r_max = g.mean = s.required_positive("radius");
        break;
      case SizeDistribution::uniform:
        g.r_min = s.required_positive("min");
        g.r_max = s.required_positive("max");
        break;
      case SizeDistribution::normal:
      case SizeDistribution::lognormal:
        g.mean = s.required_positive(g.distribution == SizeDistribution::normal ? "mean" : "median");
        g.sigma = s.non_negative(g.distribution == SizeDistribution::normal ? "std" : "sigma", 0);
        g.r_min = s.required_positive("min");
        g.r_max = s.required_positive("max");
        break;
    }
    if (g.r_max < g.r_min) s.fail("max", "must be >= min");
    s.finish();
  }
}

ParticleSource source_of(const toml::node& node, const std::string& file, const std::string& field) {
  return {file, static_cast<int>(node.source().begin.line), static_cast<int>(node.source().begin.column), field};
}

/// Reads [[particles]], [[particle_files]] and [[generators]]; `id_cells` gets, per particle, where
/// its id was given (a CSV cell; empty for a particle without one).
void read_particles(TableReader& top, Scene& scene, const std::string& base_dir,
                    std::vector<ParticleSource>& id_cells) {
  const auto explicit_list = top.tables("particles");
  for (std::size_t i = 0; i < explicit_list.size(); ++i) {
    TableReader r(*explicit_list[i], indexed("particles", i), top.file());
    ParticleConfig p;
    p.position = r.vec3("position", Vec3::Zero());
    p.velocity = r.vec3("velocity", Vec3::Zero());
    p.angular_velocity = r.vec3("angular_velocity", Vec3::Zero());
    p.radius = r.required_positive("radius");
    if (r.has("mass")) p.mass = r.positive("mass", 1);
    if (r.has("density")) p.density = r.positive("density", 1);
    p.material = read_material_name(r, scene, "material");
    r.finish();
    scene.world.particles.push_back(p);
    scene.sources.push_back(source_of(*explicit_list[i], top.file(), r.path()));
  }
  const auto files = top.tables("particle_files");
  for (std::size_t i = 0; i < files.size(); ++i) {
    TableReader r(*files[i], indexed("particle_files", i), top.file());
    const std::string name = r.string("file", "");
    if (name.empty()) r.fail("file", "is required: a CSV file with columns x, y, z, radius (see scenes/README.md)");
    const std::string material = read_material_name(r, scene, "material");
    const Vec3 offset = r.vec3("offset", Vec3::Zero());
    r.finish();
    const std::filesystem::path path = std::filesystem::path(base_dir) / name;
    if (!std::filesystem::exists(path)) r.fail("file", "file not found: " + path.string());
    ParticleCsvLayout layout;
    std::vector<ParticleConfig> loaded = read_particle_csv(path.string(), material, &layout);
    for (std::size_t k = 0; k < loaded.size(); ++k) {
      const int line = layout.lines[k];
      if (layout.material_column > 0 && !known_material(scene, loaded[k].material))
        throw InputError(path.string(), line, layout.material_column, "material",
                         "unknown material '" + loaded[k].material + "'; defined: " + material_names(scene));
      loaded[k].position += offset;
      id_cells.resize(scene.world.particles.size());
      id_cells.push_back({path.string(), line, layout.id_column, "id"});
      scene.world.particles.push_back(loaded[k]);
      scene.sources.push_back({path.string(), line, 1, r.path() + " row " + std::to_string(k + 1)});
    }
  }
  const auto generators = top.tables("generators");
  for (std::size_t i = 0; i < generators.size(); ++i) {
    TableReader r(*generators[i], indexed("generators", i), top.file());
    GeneratorConfig g;
    g.count = r.integer("count", 0);
    if (g.count <= 0) r.fail("count", "must be a positive number of particles");
    g.seed = r.unsigned_integer("seed", 1);
    g.material = read_material_name(r, scene, "material");
    g.velocity = r.vec3("velocity", Vec3::Zero());
    g.max_attempts = r.integer("max_attempts", 1000);
    g.dimension = scene.world.model.dimension;
    const toml::table* region = r.table("region");
    if (!region) r.fail("region", "is required: { type = \"box\", min = [...], max = [...] } or { type = \"cylinder\", ... }");
    {
      TableReader reg(*region, r.field("region"), top.file());
      g.region = reg.choice("type", {"box", "cylinder"}, 0) == 0 ? GeneratorRegion::box : GeneratorRegion::cylinder;
      if (g.region == GeneratorRegion::box) {
        g.min = reg.vec3("min", Vec3::Zero());
        g.max = reg.vec3("max", Vec3::Ones());
        if (!((g.max - g.min).minCoeff() >= 0)) reg.fail("max", "must be >= min in every component");
      } else {
        g.center = reg.vec3("center", Vec3::Zero());
        g.axis = reg.vec3("axis", Vec3::UnitZ());
        if (g.axis.norm() == 0) reg.fail("axis", "must be a non-zero vector");
        g.radius = reg.required_positive("radius");
        g.length = reg.non_negative("length", 0);
      }
      reg.finish();
    }
    read_size(r, g);
    r.finish();
    const std::size_t before = scene.world.particles.size();
    const GeneratorResult result = generate_particles(g, scene.world.particles);
    if (!result.ok) r.fail("count", result.message);
    for (std::size_t k = before; k < scene.world.particles.size(); ++k)
      scene.sources.push_back(source_of(*generators[i], top.file(), r.path()));
    scene.seeds.push_back(g.seed);
  }
}

}  // namespace dem::loader
