// The exact stepper: what the coefficient table saves per contact flow (docs/physics.md 5.2), and whole
// sync intervals of the frictionless dense bed with 1 and 2 threads (state hash beside each timing).
// bench/harness.h: the slowdown hook, smoke runs and BM_Calibration.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "bench/harness.h"
#include "bench/workloads.h"
#include "engine/normal_flow.h"
#include "engine/world.h"

namespace {

using namespace dem;

// A contact of the dense bed (k = 1e6 N/m, m* = 2 g, zeta 0.2) pressed at varied overlaps and rates,
// advanced over h/2 with h = 7.27e-6 s: the persistent-contact case the table serves.
struct FlowCase {
  NormalOscillator oscillator{std::sqrt(1e6 / 2.04e-3), 0.2 * std::sqrt(1e6 / 2.04e-3)};
  Real tau = 0.5 * 7.27e-6;
  std::vector<NormalState> states;
  FlowCase() {
    for (int i = 0; i < 4096; ++i) states.push_back({1e-6 * (1 + (i % 97) / 97.0), 1e-3 * ((i % 13) - 6)});
  }
};

void BM_NormalFlowInline(benchmark::State& bench) {
  const dem::bench::Slowdown slowdown("BM_NormalFlowInline");
  FlowCase c;
  Real sink = 0;
  for (auto _ : bench) {
    const auto slow = slowdown.iteration();
    for (const NormalState& s : c.states) sink += advance_normal(c.oscillator, Separation::force_zero, 0, s, c.tau).delta;
  }
  benchmark::DoNotOptimize(sink);
  bench.SetItemsProcessed(bench.iterations() * static_cast<std::int64_t>(c.states.size()));
}

void BM_NormalFlowTable(benchmark::State& bench) {
  const dem::bench::Slowdown slowdown("BM_NormalFlowTable");
  FlowCase c;
  const PropagatorCoefficients table = propagator(c.oscillator.omega0, c.oscillator.beta, c.tau);
  Real sink = 0;
  for (auto _ : bench) {
    const auto slow = slowdown.iteration();
    for (const NormalState& s : c.states)
      sink += advance_normal(c.oscillator, Separation::force_zero, 0, s, c.tau, nullptr, &table).delta;
  }
  benchmark::DoNotOptimize(sink);
  bench.SetItemsProcessed(bench.iterations() * static_cast<std::int64_t>(c.states.size()));
}

void BM_DenseBedFixedExact(benchmark::State& bench) {
  const int threads = static_cast<int>(bench.range(0));
  const dem::bench::Slowdown slowdown(dem::bench::bench_name("BM_DenseBedFixedExact", threads));
  WorldConfig config = dem::bench::benchmark_config(dem::bench::Workload::dense_bed, threads);
  config.integrator.method = Method::exact;
  config.contacts[0].sliding_friction = 0;  // the exact stepper is frictionless so far
  World world(config);
  const int intervals = dem::bench::iterations(10);
  for (auto _ : bench) {
    const auto slow = slowdown.iteration();
    for (int i = 0; i < intervals; ++i) world.advance_sync_interval();
  }
  bench.counters["particle_steps_per_s"] = benchmark::Counter(
      static_cast<double>(bench.iterations()) * intervals * world.state().size(), benchmark::Counter::kIsRate);
  char hash[32];
  std::snprintf(hash, sizeof hash, "hash=%016llx", static_cast<unsigned long long>(world.state_hash()));
  bench.SetLabel(hash);
}

BENCHMARK(BM_NormalFlowInline);
BENCHMARK(BM_NormalFlowTable);
BENCHMARK(BM_DenseBedFixedExact)->Arg(1)->Arg(2)->Iterations(dem::bench::iterations(5))->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
