#pragma once
// Materials and the dense per-pair table of contact parameters, built once at set-up.
// Damping given as restitution or Tsuji's alpha is resolved to a damping ratio here (restitution
// with the scene's separation convention), so a contact only needs its effective masses to get c.
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "engine/config.h"

namespace dem {

/// Parameters of one material pair with damping resolved to ratio, coefficient or gamma.
struct PairParams {
  Real k_n = 0;           // [N/m]
  Damping normal_damping;
  Real k_t = 0;           // [N/m]
  Damping tangential_damping;
  Real mu = 0, mu_s = 0;  // sliding and static friction [-]
  Real mu_r = 0, mu_rs = 0;  // kinetic and static rolling resistance [-]
  Real k_r = -1;          // [N m/rad]; negative: k_t R*^2
};

/// Everything the contact law needs for one contact, assembled from PairParams and the contact's
/// effective masses (see MaterialTable::constants).
struct LawConstants {
  Real k_n, c_n;        // normal spring [N/m] and dashpot [N s/m]
  Real k_t, c_t;        // tangential spring and dashpot
  Real mu, mu_s;        // sliding and static friction
  Real mu_r, mu_rs;     // rolling resistance, kinetic and static
  Real k_r, c_r;        // rolling spring [N m/rad] and dashpot [N m s/rad]
  Real i_star;          // inertia of the relative rotation (1/I_i + 1/I_j)^-1 [kg m^2]; infinite: no rotation
  Real r_star;          // effective radius [m]
};

/// What a contact's law constants are made from (MaterialTable::law_constants): the pair's class and
/// both sides' inverse masses, inverse inertias and radii (a wall: 0, 0 and infinity). Compared as
/// bits, so that equal inputs give equal constants (-0 and +0 differ).
struct LawInputs {
  std::uint16_t pair_class;
  Real inv_m_i, inv_i_i, r_i;  // [1/kg], [1/(kg m^2)], [m]
  Real inv_m_j, inv_i_j, r_j;

  bool operator==(const LawInputs& o) const {
    const auto same = [](Real a, Real b) {
      return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
    };
    return pair_class == o.pair_class && same(inv_m_i, o.inv_m_i) && same(inv_i_i, o.inv_i_i) && same(r_i, o.r_i) &&
           same(inv_m_j, o.inv_m_j) && same(inv_i_j, o.inv_i_j) && same(r_j, o.r_j);
  }
};

/// Effective masses of a contact (docs/physics.md 1.3): m*, tangential m_t, I* and R*.
struct EffectiveMasses {
  Real m_star;  // [kg]
  Real m_t;     // [kg]
  Real i_star;  // [kg m^2]
  Real r_star;  // [m]
};

/// Effective masses of a pair from inverse masses, inverse inertias and radii; a wall has inverse
/// mass and inertia 0 and radius infinity.
EffectiveMasses effective_masses(Real inv_m_i, Real inv_i_i, Real r_i, Real inv_m_j, Real inv_i_j, Real r_j);

/// Damping coefficient c [N s/m] of `d` for spring k and effective mass m (gamma uses gamma_mass).
/// Inline: the force loops call it per contact (MaterialTable::law_constants).
inline Real damping_coefficient(const Damping& d, Real k, Real m, Real gamma_mass) {
  switch (d.kind) {
    case DampingKind::damping_ratio:
      return 2 * d.value * std::sqrt(k * m);
    case DampingKind::coefficient:
      return d.value;
    case DampingKind::gamma:
      return gamma_mass * d.value;
    default:  // restitution and alpha are resolved to ratios when the table is built
      return std::numeric_limits<Real>::quiet_NaN();
  }
}

/// Inertia factor kappa of I = kappa m R^2: 2/5 for solid spheres (3D), 1/2 for discs (2D).
inline Real inertia_factor(int dimension) { return dimension == 2 ? 0.5 : 0.4; }

/// Mass of a particle [kg]: `mass` if given, else density (its own or its material's) times the
/// volume of a sphere, or of a disc of `thickness` in 2D.
Real particle_mass(const ParticleConfig& p, Real material_density, int dimension, Real thickness);

class MaterialTable {
 public:
  MaterialTable() = default;
  MaterialTable(const std::vector<MaterialConfig>& materials, const std::vector<ContactConfig>& contacts,
                Separation separation);

  std::size_t material_count() const { return density_.size(); }
  /// Index of a material by name, or -1.
  int find(const std::string& name) const;
  const std::string& name(std::uint16_t material) const { return names_[material]; }
  Real density(std::uint16_t material) const { return density_[material]; }

  std::uint16_t pair_class(std::uint16_t a, std::uint16_t b) const { return pair_class_[a * density_.size() + b]; }
  const PairParams& params(std::uint16_t pair_class) const { return params_[pair_class]; }
  std::size_t pair_class_count() const { return params_.size(); }

  bool any_friction() const { return any_friction_; }
  bool any_rolling() const { return any_rolling_; }

  /// Constants of one contact of class `pair_class` with effective masses `m`.
  LawConstants constants(std::uint16_t pair_class, const EffectiveMasses& m) const;

  /// The constants a law reads, for a contact of particles i and j with inputs `in`. The force loops call this per contact instead of storing 96 bytes
  /// per contact; particles never change mass or radius, so the values are those `constants` gives
  /// (same expressions, bit for bit). Without friction only k_n and c_n are set, without rolling
  /// no rolling fields; m_t and the divisions behind it only when the tangential damping needs them.
  template <bool Friction, bool Rolling>
  LawConstants law_constants(const LawInputs& in) const {
    if constexpr (Rolling) {
      return constants(in.pair_class,
                       effective_masses(in.inv_m_i, in.inv_i_i, in.r_i, in.inv_m_j, in.inv_i_j, in.r_j));
    } else {
      const PairParams& p = params_[in.pair_class];
      LawConstants c{};
      const Real inv_m = in.inv_m_i + in.inv_m_j;
      const Real m_star = 1 / inv_m;  // as effective_masses
      c.k_n = p.k_n;
      c.c_n = damping_coefficient(p.normal_damping, p.k_n, m_star, m_star);
      if constexpr (Friction) {
        Real m_t = 0;  // only a damping ratio refers to m_t
        if (p.tangential_damping.kind == DampingKind::damping_ratio) {
          const Real arm_j = std::isinf(in.r_j) ? 0 : in.r_j;
          m_t = 1 / (inv_m + in.r_i * in.r_i * in.inv_i_i + arm_j * arm_j * in.inv_i_j);
        }
        c.k_t = p.k_t;
        c.c_t = damping_coefficient(p.tangential_damping, p.k_t, m_t, m_star);
        c.mu = p.mu;
        c.mu_s = p.mu_s;
      }
      return c;
    }
  }

 private:
  std::vector<std::string> names_;
  std::vector<Real> density_;
  std::vector<std::uint16_t> pair_class_;  // dense material x material -> index into params_
  std::vector<PairParams> params_;
  bool any_friction_ = false;
  bool any_rolling_ = false;
};

/// The law constants of the last pair asked for, handed out again while the next pair's key
/// repeats: a row's partners, and neighbouring rows, are mostly alike (one kind of ball in a mill),
/// and with rolling resistance the constants take four divisions and four roots. `Key` must decide
/// the constants: the LawInputs themselves, or the two particles' kinds (particle_kinds.h). Scratch
/// of one thread's stretch of a loop.
template <class Key>
class LawConstantsMemo {
 public:
  /// The constants of a pair with `key`; `compute()` gives them (MaterialTable::law_constants) and is
  /// called only when the key differs from the last one.
  template <class Compute>
  const LawConstants& get(const Key& key, const Compute& compute) {
    if (!has_value_ || !(key == key_)) {
      value_ = compute();
      key_ = key;
      has_value_ = true;
    }
    return value_;
  }

 private:
  Key key_{};
  LawConstants value_{};
  bool has_value_ = false;
};

}  // namespace dem
