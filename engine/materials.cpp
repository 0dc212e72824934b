#include "engine/materials.h"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "engine/damping.h"

namespace dem {
namespace {

// Restitution and alpha become damping ratios; ratio, coefficient and gamma stay as given.
Damping resolve(const Damping& d, Separation separation) {
  switch (d.kind) {
    case DampingKind::restitution:
      return {DampingKind::damping_ratio, damping_ratio_from_restitution(d.value, separation)};
    case DampingKind::tsuji_alpha:
      return {DampingKind::damping_ratio, d.value / 2};
    default:
      return d;
  }
}

PairParams resolve(const ContactConfig& c, Separation separation) {
  PairParams p;
  p.k_n = c.normal_stiffness;
  p.normal_damping = resolve(c.normal_damping, separation);
  p.k_t = c.tangential_stiffness >= 0 ? c.tangential_stiffness : 2.0 / 7.0 * c.normal_stiffness;
  p.tangential_damping = resolve(c.tangential_damping, separation);
  p.mu = c.sliding_friction;
  p.mu_s = c.static_friction >= 0 ? c.static_friction : c.sliding_friction;
  p.mu_r = c.rolling_friction;
  p.mu_rs = c.rolling_static_friction >= 0 ? c.rolling_static_friction : c.rolling_friction;
  p.k_r = c.rolling_stiffness;
  return p;
}

}  // namespace

EffectiveMasses effective_masses(Real inv_m_i, Real inv_i_i, Real r_i, Real inv_m_j, Real inv_i_j, Real r_j) {
  EffectiveMasses m;
  const Real inv_m = inv_m_i + inv_m_j;
  m.m_star = 1 / inv_m;
  // Lever arms taken as the radii (the small overlap correction is irrelevant for damping).
  const Real arm_j = std::isinf(r_j) ? 0 : r_j;
  m.m_t = 1 / (inv_m + r_i * r_i * inv_i_i + arm_j * arm_j * inv_i_j);
  const Real inv_i = inv_i_i + inv_i_j;
  m.i_star = inv_i > 0 ? 1 / inv_i : std::numeric_limits<Real>::infinity();
  m.r_star = std::isinf(r_j) ? r_i : r_i * r_j / (r_i + r_j);
  return m;
}

Real particle_mass(const ParticleConfig& p, Real material_density, int dimension, Real thickness) {
  if (p.mass > 0) return p.mass;
  const Real volume = dimension == 2 ? pi * p.radius * p.radius * thickness
                                     : 4.0 / 3.0 * pi * p.radius * p.radius * p.radius;
  return (p.density > 0 ? p.density : material_density) * volume;
}

MaterialTable::MaterialTable(const std::vector<MaterialConfig>& materials, const std::vector<ContactConfig>& contacts,
                             Separation separation) {
  for (const auto& m : materials) {
    names_.push_back(m.name);
    density_.push_back(m.density);
  }
  const std::size_t n = materials.size();
  // Class 0 is the default (first entry without material names); specific pairs override it.
  pair_class_.assign(n * n, 0);
  params_.clear();
  int default_index = -1;
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    if (contacts[c].material_a.empty() && contacts[c].material_b.empty()) {
      default_index = static_cast<int>(c);
      break;
    }
  }
  params_.push_back(default_index >= 0 ? resolve(contacts[default_index], separation) : PairParams{});
  for (const auto& c : contacts) {
    if (c.material_a.empty() && c.material_b.empty()) continue;
    const int a = find(c.material_a), b = find(c.material_b);
    if (a < 0 || b < 0) throw std::invalid_argument("contact names an unknown material: " + c.material_a + ", " + c.material_b);
    const auto cls = static_cast<std::uint16_t>(params_.size());
    params_.push_back(resolve(c, separation));
    pair_class_[a * n + b] = cls;
    pair_class_[b * n + a] = cls;
  }
  for (const auto& p : params_) {
    any_friction_ = any_friction_ || p.mu > 0 || p.mu_s > 0;
    any_rolling_ = any_rolling_ || p.mu_r > 0 || p.mu_rs > 0;
  }
}

int MaterialTable::find(const std::string& name) const {
  for (std::size_t i = 0; i < names_.size(); ++i)
    if (names_[i] == name) return static_cast<int>(i);
  return -1;
}

LawConstants MaterialTable::constants(std::uint16_t pair_class, const EffectiveMasses& m) const {
  const PairParams& p = params_[pair_class];
  LawConstants c{};
  c.k_n = p.k_n;
  c.c_n = damping_coefficient(p.normal_damping, p.k_n, m.m_star, m.m_star);
  c.k_t = p.k_t;
  // Tangential: a ratio refers to the tangential effective mass m_t; gamma to m* (LAMMPS convention).
  c.c_t = damping_coefficient(p.tangential_damping, p.k_t, m.m_t, m.m_star);
  c.mu = p.mu;
  c.mu_s = p.mu_s;
  c.mu_r = p.mu_r;
  c.mu_rs = p.mu_rs;
  c.r_star = m.r_star;
  c.k_r = p.k_r >= 0 ? p.k_r : p.k_t * m.r_star * m.r_star;
  // Rolling dashpot for rolling about the contact point, inertia I* + m* R*^2 (3.5 I for a solid
  // sphere on a wall; docs/physics.md 2.4, Ai et al. type C), at damping ratio sqrt(2) (an engine
  // choice), not 1: in the static state the rolling spring and the tangential spring (through the lever arm) form one
  // coupled system whose translational mode is damped by c_t alone and rocks the particle. Under a
  // step load (a sphere set down on a slope) the elastic rolling torque then overshoots its static
  // value; for a sphere on a wall, k_r = k_t R^2, zeta_t = 0.5 (0.2) the overshoot is 7.7% (12%) at
  // ratio 1, 0.2% (3%) at 1.2 and 0 (0.7%) at sqrt(2) (2-DOF model of the engine's step), so a
  // hold at 0.97 of mu_rs survives its own loading (docs/physics.md 8.4). The law caps c_r at I*/h.
  c.i_star = m.i_star;
  c.c_r = std::isinf(m.i_star) ? 0
                               : 2 * std::sqrt(2.0) * std::sqrt(c.k_r * (m.i_star + m.m_star * m.r_star * m.r_star));
  return c;
}

}  // namespace dem
