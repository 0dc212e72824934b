// Fixed-step throughput of whole sync intervals on the two benchmark workloads (scenes/data), with
// 1 and 2 threads. The world is built outside the timed loop; the state hash is printed beside each
// timing so a speed-up that changes results shows at once. A fixed iteration count makes the hashes
// of the 1- and 2-thread runs comparable: they must be equal. bench/harness.h: the slowdown hook,
// smoke runs (one iteration of one interval) and BM_Calibration.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <memory>

#include "bench/harness.h"
#include "bench/workloads.h"
#include "engine/world.h"

namespace {

using dem::bench::Workload;

void run_sync_intervals(benchmark::State& bench, const char* family, Workload workload) {
  const int threads = static_cast<int>(bench.range(0));
  const dem::bench::Slowdown slowdown(dem::bench::bench_name(family, threads));
  dem::World world(dem::bench::benchmark_config(workload, threads));
  const int intervals_per_iteration = dem::bench::iterations(20);
  for (auto _ : bench) {
    const auto slow = slowdown.iteration();
    for (int i = 0; i < intervals_per_iteration; ++i) world.advance_sync_interval();
  }
  const double particle_steps = static_cast<double>(bench.iterations()) * intervals_per_iteration * world.state().size();
  bench.counters["particle_steps_per_s"] = benchmark::Counter(particle_steps, benchmark::Counter::kIsRate);
  bench.counters["contacts"] = static_cast<double>(world.pair_contacts().size() + world.wall_contacts().size());
  bench.counters["bytes_per_particle"] = static_cast<double>(world.memory_bytes()) / world.state().size();
  bench.counters["threads"] = world.thread_count();
  char hash[32];
  std::snprintf(hash, sizeof hash, "hash=%016llx", static_cast<unsigned long long>(world.state_hash()));
  bench.SetLabel(hash);
}

void BM_DenseBedFixedVerlet(benchmark::State& s) { run_sync_intervals(s, "BM_DenseBedFixedVerlet", Workload::dense_bed); }
void BM_FreeFlightFixedVerlet(benchmark::State& s) {
  run_sync_intervals(s, "BM_FreeFlightFixedVerlet", Workload::free_flight);
}

BENCHMARK(BM_DenseBedFixedVerlet)->Arg(1)->Arg(2)->Iterations(dem::bench::iterations(10))->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FreeFlightFixedVerlet)->Arg(1)->Arg(2)->Iterations(dem::bench::iterations(10))->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
