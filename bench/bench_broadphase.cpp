// Broadphase benchmarks: grid (build + pairs), k-d tree (build + pairs) and the skin check, on random
// monodisperse spheres at ~0.5 solid fraction (the density of a settled bed), n = 1e3, 1e4, 1e5.
// Data is built outside the timed loop; UseRealTime, because the work runs on oneTBB threads.
// Counters: items_per_second (particles), time_per_particle [s], pairs (printed beside each timing so a
// speed-up that changes the result shows at once). bench/harness.h: the slowdown hook and BM_Calibration.
#include "broadphase/grid.h"
#include "broadphase/kd_tree.h"
#include "broadphase/skin.h"

#include <benchmark/benchmark.h>

#include "bench/harness.h"

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

namespace {

using dem::broadphase::CandidatePairs;
using dem::broadphase::Vec3;

constexpr double radius = 0.5;  // [m]
constexpr double skin = 0.05;   // [m], a tenth of the radius

struct Bed {
  std::vector<Vec3> position;  // [m]
  std::vector<double> radius;  // [m]
};

// n spheres uniform in a cube sized for solid fraction 0.5 (overlaps ignored), fixed seed.
Bed make_bed(std::size_t n) {
  const double volume = static_cast<double>(n) * 4.0 / 3.0 * std::numbers::pi * radius * radius * radius;
  const double side = std::cbrt(volume / 0.5);
  std::mt19937_64 rng(n);
  std::uniform_real_distribution<double> coordinate(0.0, side);
  Bed bed;
  for (std::size_t i = 0; i < n; ++i) {
    bed.position.emplace_back(coordinate(rng), coordinate(rng), coordinate(rng));
    bed.radius.push_back(radius);
  }
  return bed;
}

void set_counters(benchmark::State& state, std::size_t n, std::size_t pairs) {
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * n));
  // Inverted rate of n per iteration: seconds per particle, which the console shows with an SI prefix.
  state.counters["time_per_particle"] = benchmark::Counter(
      static_cast<double>(n), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.counters["pairs"] = benchmark::Counter(static_cast<double>(pairs));
}

// The family name each broadphase's benchmark is registered under.
template <class Broadphase>
constexpr const char* family = nullptr;
template <>
constexpr const char* family<dem::broadphase::GridBroadphase> = "grid_build_and_pairs";
template <>
constexpr const char* family<dem::broadphase::KdTreeBroadphase> = "kd_tree_build_and_pairs";

template <class Broadphase>
void find_pairs(benchmark::State& state) {
  const auto n = static_cast<std::size_t>(state.range(0));
  const dem::bench::Slowdown slowdown(dem::bench::bench_name(family<Broadphase>, state.range(0)));
  const Bed bed = make_bed(n);
  Broadphase broadphase;
  CandidatePairs pairs;
  broadphase.find_pairs(bed.position, bed.radius, skin, pairs);  // warm-up: buffers reach their size
  for (auto _ : state) {
    const auto slow = slowdown.iteration();
    broadphase.find_pairs(bed.position, bed.radius, skin, pairs);
    benchmark::DoNotOptimize(pairs.partner.data());
    benchmark::ClobberMemory();
  }
  set_counters(state, n, pairs.pair_count());
}

void skin_check(benchmark::State& state) {
  const auto n = static_cast<std::size_t>(state.range(0));
  const dem::bench::Slowdown slowdown(dem::bench::bench_name("skin_check", state.range(0)));
  Bed bed = make_bed(n);
  dem::broadphase::SkinTracker tracker;
  tracker.reset(bed.position);
  for (auto& x : bed.position) x.x() += 0.1 * skin;  // moved, but no rebuild needed
  bool rebuild = false;
  for (auto _ : state) {
    const auto slow = slowdown.iteration();
    rebuild = tracker.needs_rebuild(bed.position, skin);
    benchmark::DoNotOptimize(rebuild);
  }
  set_counters(state, n, 0);
  state.counters["rebuild"] = rebuild ? 1.0 : 0.0;
}

void sizes(benchmark::internal::Benchmark* b) {
  b->RangeMultiplier(10)->Range(1000, 100000)->UseRealTime()->Unit(benchmark::kMicrosecond);
}

BENCHMARK_TEMPLATE(find_pairs, dem::broadphase::GridBroadphase)->Name(family<dem::broadphase::GridBroadphase>)->Apply(sizes);
BENCHMARK_TEMPLATE(find_pairs, dem::broadphase::KdTreeBroadphase)->Name(family<dem::broadphase::KdTreeBroadphase>)->Apply(sizes);
BENCHMARK(skin_check)->Apply(sizes);

}  // namespace

BENCHMARK_MAIN();
