// An estimate of this machine's limit per particle-step on the dense bed: the physics of
// scenes/dense_bed.toml (linear spring-dashpot in the overlap convention, tangential spring with a
// Coulomb cap by LIGGGHTS' rule, gravity, the box's six planes, velocity Verlet at dt = 7.27e-6 s) in
// the least work a step can do, on one thread:
// one pass over a half list of candidate pairs that keeps each pair's tangential spring in the
// pair's own slot (LIGGGHTS' layout; no contact list rebuilt, no adjacency, no energy books, no
// checks), forces added to both particles at once, then the kick and drift. Candidates are found once
// outside the timed loop with the engine's grid (skin 2 mm; in 2,000 steps LIGGGHTS rebuilt twice),
// so neighbour search is left out of the limit. Not deterministic across thread counts and not used
// by the engine: it is a yardstick. BM_LimitKernelDenseBedAvx2 runs the same kernel with its pair
// law four pairs at a time (x86-64 with AVX2; the same bits as the scalar kernel).
// BM_EngineDenseBed times the engine on the same particles and steps, so one run gives the ratios;
// the kinetic energy after the steps is printed beside each to show they integrate the same bed
// (chaotic in detail, equal in size).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "bench/harness.h"
#include "broadphase/grid.h"
#include "engine/world.h"

namespace {

using dem::Real;
using dem::Vec3;

constexpr Real dt = 7.27e-6, k_n = 1e6, k_t = 285714.2857142857, gamma_n = 9535.697, gamma_t = 4767.8485;
constexpr Real friction = 0.5, skin = 0.002;
const Vec3 gravity(0, 0, -9.81);
const Vec3 box_low(0, 0, 0), box_high(0.3, 0.3, 0.4);

std::unique_ptr<dem::World> dense_bed(int threads) {
  return dem::World::load(std::string(DEM_SOURCE_DIR) + "/scenes/dense_bed.toml",
                          {"run.threads=" + std::to_string(threads)});
}

struct Bed {
  std::vector<Vec3> x, v, w, f, t;
  std::vector<Real> r, inv_m, inv_i;
  std::vector<std::uint32_t> pair_i, pair_j;  // candidate pairs, i < j
  std::vector<Vec3> pair_spring;              // tangential spring per candidate pair [m]
  std::vector<Vec3> wall_spring;              // 6 per particle: -x, +x, -y, +y, -z, +z planes [m]

  Real kinetic_energy() const {
    Real e = 0;
    for (std::size_t p = 0; p < x.size(); ++p) e += 0.5 * v[p].squaredNorm() / inv_m[p];
    return e;
  }
};

Bed bed_from(const dem::World& world) {
  const dem::State& s = world.state();
  Bed b{s.position, s.velocity, s.angular_velocity, {}, {}, s.radius, s.inv_mass, s.inv_inertia, {}, {}, {}, {}};
  b.f.assign(b.x.size(), Vec3::Zero());
  b.t.assign(b.x.size(), Vec3::Zero());
  b.wall_spring.assign(6 * b.x.size(), Vec3::Zero());
  dem::broadphase::CandidatePairs candidates;
  dem::broadphase::GridBroadphase grid;
  grid.find_pairs(b.x, b.r, skin, candidates);
  for (std::size_t i = 0; i < candidates.row_count(); ++i)
    for (std::uint32_t k = candidates.row_start[i]; k < candidates.row_start[i + 1]; ++k) {
      b.pair_i.push_back(static_cast<std::uint32_t>(i));
      b.pair_j.push_back(candidates.partner[k]);
    }
  b.pair_spring.assign(b.pair_i.size(), Vec3::Zero());
  return b;
}

// One contact with normal n (from the partner to p), overlap delta, effective mass m and relative
// surface velocity u; updates the spring and returns the force on p. The normal force follows the
// scene's overlap convention (it may pull at the end of a contact, as the engine's law and LIGGGHTS'
// default do); the tangential part is LIGGGHTS' simpler rule (the spring projected without keeping its
// length, the cap on spring plus dashpot), which costs the same as the engine's.
inline Vec3 contact_force(const Vec3& n, Real delta, Real m, const Vec3& u, Vec3& spring) {
  const Real u_n = u.dot(n);
  const Vec3 u_t = u - u_n * n;
  const Real f_n = k_n * delta - gamma_n * m * u_n;
  spring += u_t * dt;
  spring -= spring.dot(n) * n;
  Vec3 f_t = -k_t * spring - gamma_t * m * u_t;
  const Real cap = friction * std::max(f_n, Real(0)), size = f_t.norm();
  if (size > cap) {
    f_t *= cap / size;
    spring = -(f_t + gamma_t * m * u_t) / k_t;
  }
  return f_n * n + f_t;
}

void start_forces(Bed& b) {
  for (std::size_t p = 0; p < b.x.size(); ++p) {
    b.f[p] = gravity / b.inv_m[p];
    b.t[p].setZero();
  }
}

// A touching pair's contact (i, j): its force on i, n x force (the torque on i is -a_i n x F, on j
// -a_j n x F) and the two lever arms; updates the spring.
struct PairContact {
  Vec3 force, arm_torque;
  Real a_i, a_j;
};

PairContact pair_contact(const Bed& b, std::uint32_t i, std::uint32_t j, Real dist2, Vec3& spring) {
  const Real dist = std::sqrt(dist2), delta = b.r[i] + b.r[j] - dist;
  const Vec3 normal = (b.x[i] - b.x[j]) / dist;
  const Real a_i = b.r[i] - 0.5 * delta, a_j = b.r[j] - 0.5 * delta;
  const Vec3 u = b.v[i] - b.v[j] - (a_i * b.w[i] + a_j * b.w[j]).cross(normal);
  const Real m = 1 / (b.inv_m[i] + b.inv_m[j]);
  const Vec3 force = contact_force(normal, delta, m, u, spring);
  return {force, normal.cross(force), a_i, a_j};
}

void add_contact(Bed& b, std::uint32_t i, std::uint32_t j, const PairContact& c) {
  b.f[i] += c.force;
  b.f[j] -= c.force;
  b.t[i] -= c.a_i * c.arm_torque;
  b.t[j] -= c.a_j * c.arm_torque;
}

// The squared distance of pair (i, j) when it touches, else a negative number.
Real touching_dist2(const Bed& b, std::uint32_t i, std::uint32_t j) {
  const Real reach = b.r[i] + b.r[j], dist2 = (b.x[i] - b.x[j]).squaredNorm();
  return dist2 < reach * reach ? dist2 : -1;
}

void pair_forces(Bed& b) {
  for (std::size_t k = 0; k < b.pair_i.size(); ++k) {
    const std::uint32_t i = b.pair_i[k], j = b.pair_j[k];
    const Real dist2 = touching_dist2(b, i, j);
    if (dist2 < 0) {
      b.pair_spring[k].setZero();
      continue;
    }
    add_contact(b, i, j, pair_contact(b, i, j, dist2, b.pair_spring[k]));
  }
}

void wall_forces(Bed& b) {
  for (std::size_t p = 0; p < b.x.size(); ++p) {
    for (int side = 0; side < 6; ++side) {
      const int axis = side / 2;
      const bool high = side % 2 == 1;
      const Real gap = high ? box_high[axis] - b.x[p][axis] : b.x[p][axis] - box_low[axis];
      Vec3& spring = b.wall_spring[6 * p + side];
      if (gap >= b.r[p]) {
        spring.setZero();
        continue;
      }
      Vec3 normal = Vec3::Zero();
      normal[axis] = high ? -1 : 1;  // from the wall to the particle
      const Real delta = b.r[p] - gap, a = b.r[p] - 0.5 * delta;  // lever arm to mid-overlap, as the engine
      const Vec3 u = b.v[p] - (a * b.w[p]).cross(normal);
      const Vec3 force = contact_force(normal, delta, 1 / b.inv_m[p], u, spring);
      b.f[p] += force;
      b.t[p] -= a * normal.cross(force);
    }
  }
}

void kick(Bed& b) {
  for (std::size_t p = 0; p < b.x.size(); ++p) {
    b.v[p] += (0.5 * dt * b.inv_m[p]) * b.f[p];
    b.w[p] += (0.5 * dt * b.inv_i[p]) * b.t[p];
  }
}

void compute_forces(Bed& b) {
  start_forces(b);
  pair_forces(b);
  wall_forces(b);
}

void step(Bed& b) {
  kick(b);
  for (std::size_t p = 0; p < b.x.size(); ++p) b.x[p] += dt * b.v[p];
  compute_forces(b);
  kick(b);
}

#if defined(__x86_64__)
// The same kernel with the pair law on AVX2, four pairs at a time, the same operations in the same
// order as contact_force, in two forms (the benchmark's argument):
//   0  filtered: a pass over the candidates finds the touching ones (and clears the springs of the
//      others), the law runs on four touching pairs at once, and the forces are then added to the
//      particles one contact at a time in candidate order;
//   1  unfiltered: the law runs on four consecutive candidates at once, touching or not, and only the
//      touching ones' forces are added, in candidate order.
// Either way the particles' sums, and the state after any number of steps, are those of the scalar
// kernel bit for bit (checked after the run). The question it answers: what vector units buy on this
// physics, before the engine is rebuilt around them.
struct VectorBed {
  Bed bed;
  std::vector<Real> spring_x, spring_y, spring_z;  // per candidate pair, by coordinate [m]
  std::vector<std::uint32_t> touching;            // candidate pairs that overlap this step, ascending
  std::vector<Real> force_out, torque_arm_out;    // per touching pair: force (3) and n x force (3)
  std::vector<Real> arm_i_out, arm_j_out;
};

namespace lanes {

using V = __m256d;

// The masked form with every lane on: the plain one leaves its source undefined, which GCC warns about.
[[gnu::target("avx2")]] inline V gather(const Real* base, __m128i index) {
  const V all = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
  return _mm256_mask_i32gather_pd(_mm256_setzero_pd(), base, index, all, 8);
}

// x0^2 + x1^2 + x2^2 summed as Eigen sums a 3-vector's squared norm or dot product.
[[gnu::target("avx2")]] inline V dot3(V a0, V a1, V a2, V b0, V b1, V b2) {
  return _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(a0, b0), _mm256_mul_pd(a1, b1)), _mm256_mul_pd(a2, b2));
}

// The lanes whose pair (i, j) touches: the scalar kernel's test, dist^2 < (r_i + r_j)^2, on the same numbers.
[[gnu::target("avx2")]] inline V touching_lanes(const Bed& b, __m128i i, __m128i j) {
  const Real* x = b.x[0].data();
  const __m128i i3 = _mm_add_epi32(_mm_add_epi32(i, i), i), j3 = _mm_add_epi32(_mm_add_epi32(j, j), j);
  const __m128i one = _mm_set1_epi32(1), two = _mm_set1_epi32(2);
  const V d0 = _mm256_sub_pd(gather(x, i3), gather(x, j3));
  const V d1 = _mm256_sub_pd(gather(x, _mm_add_epi32(i3, one)), gather(x, _mm_add_epi32(j3, one)));
  const V d2 = _mm256_sub_pd(gather(x, _mm_add_epi32(i3, two)), gather(x, _mm_add_epi32(j3, two)));
  const V reach = _mm256_add_pd(gather(b.r.data(), i), gather(b.r.data(), j));
  return _mm256_cmp_pd(dot3(d0, d1, d2, d0, d1, d2), _mm256_mul_pd(reach, reach), _CMP_LT_OQ);
}

}  // namespace lanes

[[gnu::target("avx2")]] void find_touching(VectorBed& vb) {
  using namespace lanes;
  Bed& b = vb.bed;
  const std::size_t count = b.pair_i.size();
  vb.touching.clear();
  std::size_t k = 0;
  for (; k + 4 <= count; k += 4) {
    const __m128i i = _mm_loadu_si128(reinterpret_cast<const __m128i*>(&b.pair_i[k]));
    const __m128i j = _mm_loadu_si128(reinterpret_cast<const __m128i*>(&b.pair_j[k]));
    const V touch = touching_lanes(b, i, j);
    const __m256i clear = _mm256_xor_si256(_mm256_castpd_si256(touch), _mm256_set1_epi64x(-1));
    const V zero = _mm256_setzero_pd();
    _mm256_maskstore_pd(&vb.spring_x[k], clear, zero);
    _mm256_maskstore_pd(&vb.spring_y[k], clear, zero);
    _mm256_maskstore_pd(&vb.spring_z[k], clear, zero);
    for (unsigned mask = static_cast<unsigned>(_mm256_movemask_pd(touch)); mask; mask &= mask - 1)
      vb.touching.push_back(static_cast<std::uint32_t>(k + __builtin_ctz(mask)));
  }
  for (; k < count; ++k) {
    const std::uint32_t i = b.pair_i[k], j = b.pair_j[k];
    const Real reach = b.r[i] + b.r[j];
    if ((b.x[i] - b.x[j]).squaredNorm() < reach * reach) {
      vb.touching.push_back(static_cast<std::uint32_t>(k));
    } else {
      vb.spring_x[k] = vb.spring_y[k] = vb.spring_z[k] = 0;
    }
  }
}

// contact_force and its pair's geometry for touching[t .. t + 4), written to the *_out arrays.
// contact_force for four pairs (i, j) with their springs s, as the scalar kernel computes it, lane by
// lane. Lanes whose pair does not touch compute numbers nobody reads.
struct FourContacts {
  lanes::V spring[3], force[3], arm_torque[3], arm_i, arm_j;
};

[[gnu::target("avx2"), gnu::always_inline]] inline FourContacts four_contacts(const Bed& b, __m128i i, __m128i j, const lanes::V (&spring)[3]) {
  using namespace lanes;
  const __m128i i3 = _mm_add_epi32(_mm_add_epi32(i, i), i), j3 = _mm_add_epi32(_mm_add_epi32(j, j), j);
  const __m128i one = _mm_set1_epi32(1), two = _mm_set1_epi32(2);
  const __m128i i3y = _mm_add_epi32(i3, one), i3z = _mm_add_epi32(i3, two);
  const __m128i j3y = _mm_add_epi32(j3, one), j3z = _mm_add_epi32(j3, two);
  const Real *x = b.x[0].data(), *v = b.v[0].data(), *w = b.w[0].data();
  const auto add = _mm256_add_pd, sub = _mm256_sub_pd, mul = _mm256_mul_pd, div = _mm256_div_pd;
  const auto set = _mm256_set1_pd;

  const V d0 = sub(gather(x, i3), gather(x, j3)), d1 = sub(gather(x, i3y), gather(x, j3y)),
          d2 = sub(gather(x, i3z), gather(x, j3z));
  const V r_i = gather(b.r.data(), i), r_j = gather(b.r.data(), j);
  const V reach = add(r_i, r_j);
  const V dist = _mm256_sqrt_pd(dot3(d0, d1, d2, d0, d1, d2)), delta = sub(reach, dist);
  const V n0 = div(d0, dist), n1 = div(d1, dist), n2 = div(d2, dist);
  const V half_delta = mul(set(0.5), delta);
  const V a_i = sub(r_i, half_delta), a_j = sub(r_j, half_delta);
  // u = v_i - v_j - (a_i w_i + a_j w_j) x n
  const V c0 = add(mul(a_i, gather(w, i3)), mul(a_j, gather(w, j3)));
  const V c1 = add(mul(a_i, gather(w, i3y)), mul(a_j, gather(w, j3y)));
  const V c2 = add(mul(a_i, gather(w, i3z)), mul(a_j, gather(w, j3z)));
  const V u0 = sub(sub(gather(v, i3), gather(v, j3)), sub(mul(c1, n2), mul(c2, n1)));
  const V u1 = sub(sub(gather(v, i3y), gather(v, j3y)), sub(mul(c2, n0), mul(c0, n2)));
  const V u2 = sub(sub(gather(v, i3z), gather(v, j3z)), sub(mul(c0, n1), mul(c1, n0)));
  const V m = div(set(1), add(gather(b.inv_m.data(), i), gather(b.inv_m.data(), j)));
  // contact_force
  const V u_n = dot3(u0, u1, u2, n0, n1, n2);
  const V ut0 = sub(u0, mul(u_n, n0)), ut1 = sub(u1, mul(u_n, n1)), ut2 = sub(u2, mul(u_n, n2));
  const V f_n = sub(mul(set(k_n), delta), mul(mul(set(gamma_n), m), u_n));
  const V h = set(dt);
  V s0 = add(spring[0], mul(ut0, h)), s1 = add(spring[1], mul(ut1, h)), s2 = add(spring[2], mul(ut2, h));
  const V s_n = dot3(s0, s1, s2, n0, n1, n2);
  s0 = sub(s0, mul(s_n, n0)), s1 = sub(s1, mul(s_n, n1)), s2 = sub(s2, mul(s_n, n2));
  const V gm = mul(set(gamma_t), m), minus_k = set(-k_t);
  V ft0 = sub(mul(minus_k, s0), mul(gm, ut0)), ft1 = sub(mul(minus_k, s1), mul(gm, ut1)),
    ft2 = sub(mul(minus_k, s2), mul(gm, ut2));
  const V cap = mul(set(friction), _mm256_max_pd(f_n, _mm256_setzero_pd()));
  const V size = _mm256_sqrt_pd(dot3(ft0, ft1, ft2, ft0, ft1, ft2));
  const V slide = _mm256_cmp_pd(size, cap, _CMP_GT_OQ);
  if (_mm256_movemask_pd(slide)) {
    const V scale = div(cap, size), kt = set(k_t);
    const V g0 = mul(ft0, scale), g1 = mul(ft1, scale), g2 = mul(ft2, scale);
    const V zero = _mm256_setzero_pd();
    s0 = _mm256_blendv_pd(s0, div(sub(zero, add(g0, mul(gm, ut0))), kt), slide);
    s1 = _mm256_blendv_pd(s1, div(sub(zero, add(g1, mul(gm, ut1))), kt), slide);
    s2 = _mm256_blendv_pd(s2, div(sub(zero, add(g2, mul(gm, ut2))), kt), slide);
    ft0 = _mm256_blendv_pd(ft0, g0, slide), ft1 = _mm256_blendv_pd(ft1, g1, slide);
    ft2 = _mm256_blendv_pd(ft2, g2, slide);
  }
  const V f0 = add(mul(f_n, n0), ft0), f1 = add(mul(f_n, n1), ft1), f2 = add(mul(f_n, n2), ft2);
  return FourContacts{{s0, s1, s2},
                      {f0, f1, f2},
                      {sub(mul(n1, f2), mul(n2, f1)), sub(mul(n2, f0), mul(n0, f2)), sub(mul(n0, f1), mul(n1, f0))},
                      a_i,
                      a_j};
}

// The lanes of a FourContacts as plain numbers.
struct FourOut {
  alignas(32) Real spring[3][4], force[3][4], arm_torque[3][4], arm_i[4], arm_j[4];
};

[[gnu::target("avx2"), gnu::always_inline]] inline void store(const FourContacts& c, FourOut& out) {
  for (int a = 0; a < 3; ++a) {
    _mm256_store_pd(out.spring[a], c.spring[a]);
    _mm256_store_pd(out.force[a], c.force[a]);
    _mm256_store_pd(out.arm_torque[a], c.arm_torque[a]);
  }
  _mm256_store_pd(out.arm_i, c.arm_i);
  _mm256_store_pd(out.arm_j, c.arm_j);
}

// The touching pairs touching[t .. t + 4): springs updated, forces written to the *_out arrays.
[[gnu::target("avx2")]] void four_touching(VectorBed& vb, std::size_t t) {
  using namespace lanes;
  const Bed& b = vb.bed;
  alignas(16) std::uint32_t pi[4], pj[4];
  const std::uint32_t* pk = &vb.touching[t];
  for (int l = 0; l < 4; ++l) pi[l] = b.pair_i[pk[l]], pj[l] = b.pair_j[pk[l]];
  const __m128i k = _mm_loadu_si128(reinterpret_cast<const __m128i*>(pk));
  const V spring[3] = {gather(vb.spring_x.data(), k), gather(vb.spring_y.data(), k), gather(vb.spring_z.data(), k)};
  FourOut out;
  store(four_contacts(b, _mm_load_si128(reinterpret_cast<const __m128i*>(pi)),
                      _mm_load_si128(reinterpret_cast<const __m128i*>(pj)), spring),
        out);
  for (int l = 0; l < 4; ++l) {
    vb.spring_x[pk[l]] = out.spring[0][l], vb.spring_y[pk[l]] = out.spring[1][l], vb.spring_z[pk[l]] = out.spring[2][l];
    for (int a = 0; a < 3; ++a) {
      vb.force_out[3 * (t + l) + a] = out.force[a][l];
      vb.torque_arm_out[3 * (t + l) + a] = out.arm_torque[a][l];
    }
    vb.arm_i_out[t + l] = out.arm_i[l], vb.arm_j_out[t + l] = out.arm_j[l];
  }
}

// The candidates k0 .. k0 + 4, contiguous: the law on all four, the touching ones' forces added to
// their particles in candidate order, the others' springs cleared.
[[gnu::target("avx2")]] void four_candidates(VectorBed& vb, std::size_t k0) {
  using namespace lanes;
  Bed& b = vb.bed;
  const __m128i i = _mm_loadu_si128(reinterpret_cast<const __m128i*>(&b.pair_i[k0]));
  const __m128i j = _mm_loadu_si128(reinterpret_cast<const __m128i*>(&b.pair_j[k0]));
  const V touch = touching_lanes(b, i, j);
  const int touching = _mm256_movemask_pd(touch);
  const V spring[3] = {_mm256_loadu_pd(&vb.spring_x[k0]), _mm256_loadu_pd(&vb.spring_y[k0]),
                       _mm256_loadu_pd(&vb.spring_z[k0])};
  const FourContacts c = four_contacts(b, i, j, spring);
  _mm256_storeu_pd(&vb.spring_x[k0], _mm256_and_pd(c.spring[0], touch));
  _mm256_storeu_pd(&vb.spring_y[k0], _mm256_and_pd(c.spring[1], touch));
  _mm256_storeu_pd(&vb.spring_z[k0], _mm256_and_pd(c.spring[2], touch));
  if (!touching) return;
  FourOut out;
  store(c, out);
  for (int l = 0; l < 4; ++l) {
    if (!(touching >> l & 1)) continue;
    const PairContact contact{Vec3(out.force[0][l], out.force[1][l], out.force[2][l]),
                              Vec3(out.arm_torque[0][l], out.arm_torque[1][l], out.arm_torque[2][l]), out.arm_i[l],
                              out.arm_j[l]};
    add_contact(b, b.pair_i[k0 + l], b.pair_j[k0 + l], contact);
  }
}

// The variant without the touching pass: four candidates at a time, contiguous, the law on all four
// and its results kept for the touching ones only.
void unfiltered_pair_forces(VectorBed& vb) {
  Bed& b = vb.bed;
  const std::size_t count = b.pair_i.size();
  std::size_t k = 0;
  for (; k + 4 <= count; k += 4) four_candidates(vb, k);
  for (; k < count; ++k) {
    const std::uint32_t i = b.pair_i[k], j = b.pair_j[k];
    const Real dist2 = touching_dist2(b, i, j);
    Vec3 spring = Vec3::Zero();
    if (dist2 >= 0) {
      spring = Vec3(vb.spring_x[k], vb.spring_y[k], vb.spring_z[k]);
      add_contact(b, i, j, pair_contact(b, i, j, dist2, spring));
    }
    vb.spring_x[k] = spring.x(), vb.spring_y[k] = spring.y(), vb.spring_z[k] = spring.z();
  }
}

void vector_pair_forces(VectorBed& vb) {
  Bed& b = vb.bed;
  find_touching(vb);
  const std::size_t count = vb.touching.size();
  vb.force_out.resize(3 * count);
  vb.torque_arm_out.resize(3 * count);
  vb.arm_i_out.resize(count);
  vb.arm_j_out.resize(count);
  std::size_t t = 0;
  for (; t + 4 <= count; t += 4) four_touching(vb, t);
  for (; t < count; ++t) {  // the last few through the scalar law
    const std::uint32_t k = vb.touching[t], i = b.pair_i[k], j = b.pair_j[k];
    Vec3 spring(vb.spring_x[k], vb.spring_y[k], vb.spring_z[k]);
    const PairContact c = pair_contact(b, i, j, (b.x[i] - b.x[j]).squaredNorm(), spring);
    vb.spring_x[k] = spring.x(), vb.spring_y[k] = spring.y(), vb.spring_z[k] = spring.z();
    for (int a = 0; a < 3; ++a) vb.force_out[3 * t + a] = c.force[a], vb.torque_arm_out[3 * t + a] = c.arm_torque[a];
    vb.arm_i_out[t] = c.a_i, vb.arm_j_out[t] = c.a_j;
  }
  for (t = 0; t < count; ++t) {
    const std::uint32_t k = vb.touching[t];
    const PairContact c{Vec3(vb.force_out[3 * t], vb.force_out[3 * t + 1], vb.force_out[3 * t + 2]),
                        Vec3(vb.torque_arm_out[3 * t], vb.torque_arm_out[3 * t + 1], vb.torque_arm_out[3 * t + 2]),
                        vb.arm_i_out[t], vb.arm_j_out[t]};
    add_contact(b, b.pair_i[k], b.pair_j[k], c);
  }
}

constexpr int steps_per_iteration = 100;

void BM_LimitKernelDenseBed(benchmark::State& bench) {
  const std::unique_ptr<dem::World> world = dense_bed(1);
  Bed b = bed_from(*world);
  const std::vector<Vec3> start = b.x;
  compute_forces(b);
  const int steps = dem::bench::iterations(steps_per_iteration);
  for (auto _ : bench)
    for (int s = 0; s < steps; ++s) step(b);
  const double particle_steps = static_cast<double>(bench.iterations()) * steps * b.x.size();
  bench.counters["particle_steps_per_s"] = benchmark::Counter(particle_steps, benchmark::Counter::kIsRate);
  bench.counters["candidates_per_particle"] = static_cast<double>(b.pair_i.size()) / b.x.size();
  bench.counters["kinetic_energy_J"] = b.kinetic_energy();
  // The candidates stay complete while no particle has moved more than skin/2 since they were found.
  Real moved = 0;
  for (std::size_t p = 0; p < b.x.size(); ++p) moved = std::max(moved, (b.x[p] - start[p]).norm());
  if (moved > 0.5 * skin) bench.SkipWithError("a particle moved more than skin/2: the candidate list is stale");
  bench.counters["max_displacement_m"] = moved;
}

void vector_step(VectorBed& vb, bool filtered) {
  Bed& b = vb.bed;
  kick(b);
  for (std::size_t p = 0; p < b.x.size(); ++p) b.x[p] += dt * b.v[p];
  start_forces(b);
  if (filtered)
    vector_pair_forces(vb);
  else
    unfiltered_pair_forces(vb);
  wall_forces(b);
  kick(b);
}

void BM_LimitKernelDenseBedAvx2(benchmark::State& bench) {
  const bool filtered = bench.range(0) == 0;
  const std::unique_ptr<dem::World> world = dense_bed(1);
  VectorBed vb{bed_from(*world), {}, {}, {}, {}, {}, {}, {}, {}};
  const std::size_t candidates = vb.bed.pair_i.size();
  vb.spring_x.assign(candidates, 0), vb.spring_y.assign(candidates, 0), vb.spring_z.assign(candidates, 0);
  Bed scalar = vb.bed;  // the scalar kernel from the same start, for the bitwise check
  compute_forces(scalar);
  start_forces(vb.bed), vector_pair_forces(vb), wall_forces(vb.bed);  // the same start forces either way
  const int steps = dem::bench::iterations(steps_per_iteration);
  for (auto _ : bench)
    for (int s = 0; s < steps; ++s) vector_step(vb, filtered);
  const double particle_steps = static_cast<double>(bench.iterations()) * steps * vb.bed.x.size();
  bench.counters["particle_steps_per_s"] = benchmark::Counter(particle_steps, benchmark::Counter::kIsRate);
  bench.counters["kinetic_energy_J"] = vb.bed.kinetic_energy();
  for (std::int64_t s = 0; s < bench.iterations() * steps; ++s) step(scalar);
  if (scalar.x != vb.bed.x || scalar.v != vb.bed.v || scalar.w != vb.bed.w)
    bench.SkipWithError("the AVX2 kernel's state differs from the scalar kernel's");
}

// Registered only where the processor has AVX2.
const bool avx2_kernel_registered = __builtin_cpu_supports("avx2") &&
                                    benchmark::RegisterBenchmark("BM_LimitKernelDenseBedAvx2", BM_LimitKernelDenseBedAvx2)
                                        ->Arg(0)
                                        ->Arg(1)
                                        ->Iterations(dem::bench::iterations(5))
                                        ->UseRealTime()
                                        ->Unit(benchmark::kMillisecond);
#endif

void BM_EngineDenseBed(benchmark::State& bench) {
  const int threads = static_cast<int>(bench.range(0));
  const std::unique_ptr<dem::World> world = dense_bed(threads);
  const int steps = dem::bench::iterations(steps_per_iteration);
  for (auto _ : bench)
    for (int s = 0; s < steps; ++s) world->advance_sync_interval();
  const double particle_steps = static_cast<double>(bench.iterations()) * steps * world->particle_count();
  bench.counters["particle_steps_per_s"] = benchmark::Counter(particle_steps, benchmark::Counter::kIsRate);
  bench.counters["kinetic_energy_J"] = world->energies().kinetic;
  bench.counters["threads"] = world->thread_count();
  char hash[32];
  std::snprintf(hash, sizeof hash, "hash=%016llx", static_cast<unsigned long long>(world->state_hash()));
  bench.SetLabel(hash);
}

// 5 iterations of 100 steps: the kinetic energies compare after the same 500 steps, within which no
// particle of the settling bed moves half the skin (over 1,000 steps one does: the kernel would need a
// candidate rebuild).
BENCHMARK(BM_LimitKernelDenseBed)->Iterations(dem::bench::iterations(5))->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_EngineDenseBed)->Arg(1)->Arg(2)->Iterations(dem::bench::iterations(5))->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
