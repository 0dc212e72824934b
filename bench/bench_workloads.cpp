// Free flight against dense contact at N = 1e3, 1e4, 1e5: whole sync intervals for
// fixed and doubling control, both steppers, 1 and 2 threads; and the stages of a Verlet step timed
// one by one through the engine's own stage functions. bench/workloads.py turns the JSON into the
// report in docs/workloads/.
//
// Names: interval/<workload>/<control>/<method>/n:<N>/threads:<T> and
//        stage/<workload>/<stage>/n:<N>/threads:<T>, with workload dense|free, control fixed|doubling,
//        method verlet|exact, stage grid|contacts|forces|integrate.
// 1e6 particles (tiled copies of the shipped block) run only with DEM_BENCH_LARGE=1 in the
// environment (then still selectable with --benchmark_filter=n:1000000/).
//
// Whole intervals: the world is built and advanced one interval (warm-up: capacities, first
// contact list) outside the timed loop; each iteration advances a fixed number of intervals, so the
// state hash in the label must be equal for 1 and 2 threads. Counters (per second are rates over the
// timed loop):
//   particle_steps_per_s  World counters' particle_steps (every trial and retry of doubling counted)
//   contacts_per_s        contacts at the end times force evaluations per particle, per second
//   bytes_per_particle    World::memory_bytes() / N after the run
//   steps_per_interval, force_evals_per_interval, rebuilds_per_interval, rejected_per_interval:
//                         World counters per particle (steps, evals) or per interval (rebuilds)
//   sim_time_per_interval the sync interval [s]; fixed: dt = 7.27e-6 s, doubling: dt_base 2^level_max
// Doubling uses dt_base = dt and level_max = 3 (8 dt per interval), other keys at their defaults
// (tolerance 1e-2). The exact stepper runs with friction zeroed (it is frictionless for pairs).
//
// Stages (Verlet kernels of the workload's contact law, on a copy of the warmed-up world's state, in
// a task arena of T threads like the World's):
//   grid       broadphase::GridBroadphase::find_pairs (cell sort and candidate pairs with the skin)
//   contacts   update_pair_contacts + build_pair_adjacency + update_wall_contacts
//   forces     the law's pair and wall force loops + gather_forces
//   integrate  kick(h/2), drift(h), kick(h/2)
// What a whole interval costs beyond its stages (skin check, finite-state check, and under doubling
// the islands, error estimates, redos and bookkeeping) is left to the report to subtract.
//
// bench/harness.h: the slowdown hook, BM_Calibration, and smoke runs (DEM_BENCH_SMOKE=1: one
// iteration of one interval, or of one stage call, at every size).
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include <tbb/task_arena.h>

#include "bench/harness.h"
#include "bench/scaled_workloads.h"
#include "broadphase/grid.h"
#include "engine/contacts.h"
#include "engine/forces.h"
#include "engine/integrators.h"
#include "engine/world.h"

namespace {

using namespace dem;
using dem::bench::Workload;

constexpr int doubling_level_max = 3;

struct Case {
  Workload workload;
  std::size_t n;
  int threads;
};

const char* workload_name(Workload w) { return w == Workload::dense_bed ? "dense" : "free"; }

WorldConfig case_config(const Case& c, Control control, Method method) {
  WorldConfig config = dem::bench::scaled_config(c.workload, c.n, c.threads);
  config.integrator.control = control;
  config.integrator.method = method;
  if (control == Control::doubling) {
    config.integrator.dt_base = config.integrator.dt;
    config.integrator.level_max = doubling_level_max;
  }
  if (method == Method::exact)
    for (ContactConfig& contact : config.contacts) contact.sliding_friction = 0;
  return config;
}

void set_hash_label(benchmark::State& bench, std::uint64_t hash) {
  char label[40];
  std::snprintf(label, sizeof label, "hash=%016llx", static_cast<unsigned long long>(hash));
  bench.SetLabel(label);
}

// Particle-steps one iteration should hold, roughly, so that every case takes well under a second.
int intervals_per_iteration(std::size_t n, Control control, Method method) {
  double budget = 4e5;                                   // particle-steps
  if (control == Control::doubling) budget /= 3 * 8;     // three trials of 8 steps per interval
  if (method == Method::exact) budget /= 4;              // a quarter of Verlet's rate
  return dem::bench::iterations(std::max(1, static_cast<int>(budget / static_cast<double>(n))));
}

void run_intervals(benchmark::State& bench, const std::string& name, const Case& c, Control control, Method method,
                   int intervals) {
  const dem::bench::Slowdown slowdown(name);
  World world(case_config(c, control, method));
  if (world.advance_sync_interval() != StepStatus::ok) {
    bench.SkipWithError("warm-up interval diverged");
    return;
  }
  const RunCounters before = world.counters();
  bool ok = true;
  for (auto _ : bench) {
    const auto slow = slowdown.iteration();
    for (int i = 0; i < intervals; ++i) ok = world.advance_sync_interval() == StepStatus::ok && ok;
  }
  if (!ok) {
    bench.SkipWithError("a timed interval diverged");
    return;
  }
  const RunCounters& after = world.counters();
  const double n = static_cast<double>(world.state().size());
  const double done = static_cast<double>(bench.iterations()) * intervals;
  const double steps = static_cast<double>(after.particle_steps - before.particle_steps);
  const double evals = static_cast<double>(after.force_evaluations - before.force_evaluations);
  const double contacts = static_cast<double>(world.pair_contacts().size() + world.wall_contacts().size());
  bench.counters["particle_steps_per_s"] = benchmark::Counter(steps, benchmark::Counter::kIsRate);
  bench.counters["contacts_per_s"] = benchmark::Counter(contacts * evals / n, benchmark::Counter::kIsRate);
  bench.counters["bytes_per_particle"] = static_cast<double>(world.memory_bytes()) / n;
  bench.counters["n"] = n;
  bench.counters["threads"] = world.thread_count();
  bench.counters["contacts"] = contacts;
  bench.counters["intervals"] = done;
  bench.counters["steps_per_interval"] = steps / n / done;
  bench.counters["force_evals_per_interval"] = evals / n / done;
  bench.counters["rejected_per_interval"] =
      static_cast<double>(after.rejected_steps - before.rejected_steps) / n / done;
  bench.counters["rebuilds_per_interval"] =
      static_cast<double>(after.pair_rebuilds - before.pair_rebuilds) / done;
  bench.counters["sim_time_per_interval"] = world.sync_interval();
  set_hash_label(bench, world.state_hash());
}

enum class Stage { grid, contacts, forces, integrate };
const char* stage_name(Stage s) {
  switch (s) {
    case Stage::grid: return "grid";
    case Stage::contacts: return "contacts";
    case Stage::forces: return "forces";
    case Stage::integrate: return "integrate";
  }
  return "?";
}

// The stage inputs of a warmed-up world, copied out so the stage functions run on their own data.
struct StageData {
  State state;
  MaterialTable materials;
  Walls walls;
  ForceKernels kernels;
  Vec3 gravity;
  int dimension;
  Real h, skin;
  broadphase::GridBroadphase grid;
  broadphase::CandidatePairs candidates;
  PairContacts pairs;
  WallContacts wall_contacts;
  ContactAdjacency adjacency;
  ContactWorkspace workspace;
};

void run_stage(benchmark::State& bench, const std::string& name, const Case& c, Stage stage) {
  const dem::bench::Slowdown slowdown(name);
  WorldConfig config = case_config(c, Control::fixed, Method::verlet);
  config.broadphase.sort_interval = 0;  // the compact list's stages below need slots in id order
  auto world = std::make_unique<World>(config);
  world->advance_sync_interval();
  auto d = std::make_unique<StageData>();
  d->state = world->state();
  d->materials = world->materials();
  d->walls = world->walls();
  d->kernels = select_force_kernels(config.model.separation, world->materials().any_friction(), RollingKind::none);
  d->pairs.parts = {world->materials().any_friction(), false, false};  // the parts those kernels use
  d->gravity = config.model.gravity;
  d->dimension = config.model.dimension;
  d->h = world->sync_interval();
  d->skin = world->skin();
  const std::uint64_t hash = world->state_hash();
  world.reset();
  tbb::task_arena arena(c.threads);
  const std::size_t n = d->state.size();
  auto contacts = [&] {
    update_pair_contacts(d->state, d->candidates, d->materials, d->pairs, d->workspace);
    build_pair_adjacency(n, d->pairs, d->adjacency);
    update_wall_contacts(d->state, d->walls, d->materials, d->wall_contacts, d->workspace, d->adjacency.wall_start);
  };
  auto forces = [&] {
    d->kernels.pair_forces(d->state, d->materials, d->pairs, d->h, DashpotVelocity{});
    d->kernels.wall_forces(d->state, d->materials, d->walls, d->wall_contacts, d->workspace.wall_touch, d->h,
                           DashpotVelocity{});
    gather_forces(d->state, d->pairs, d->wall_contacts, d->adjacency, d->kernels.uses_rotation, d->dimension);
  };
  arena.execute([&] {  // the inputs each stage reads, as the World has them mid-step
    d->grid.find_pairs(d->state.position, d->state.radius, d->skin, d->candidates);
    contacts();
    forces();
  });
  for (auto _ : bench) {
    const auto slow = slowdown.iteration();
    arena.execute([&] {
      switch (stage) {
        case Stage::grid: d->grid.find_pairs(d->state.position, d->state.radius, d->skin, d->candidates); break;
        case Stage::contacts: contacts(); break;
        case Stage::forces: forces(); break;
        case Stage::integrate:
          kick(d->state, 0.5 * d->h, d->gravity, d->kernels.uses_rotation, d->dimension);
          drift(d->state, d->h);
          kick(d->state, 0.5 * d->h, d->gravity, d->kernels.uses_rotation, d->dimension);
          break;
      }
    });
  }
  const double calls = static_cast<double>(bench.iterations());
  bench.counters["particle_steps_per_s"] = benchmark::Counter(calls * static_cast<double>(n), benchmark::Counter::kIsRate);
  bench.counters["n"] = static_cast<double>(n);
  bench.counters["threads"] = c.threads;
  bench.counters["contacts"] = static_cast<double>(d->pairs.size() + d->wall_contacts.size());
  bench.counters["candidate_pairs"] = static_cast<double>(d->candidates.partner.size());
  set_hash_label(bench, hash);  // of the world the stage inputs were copied from
}

void register_all() {
  std::vector<std::size_t> sizes = {1000, 10000, 100000};
  const char* large = std::getenv("DEM_BENCH_LARGE");
  if (large && std::string(large) == "1") sizes.push_back(1000000);
  for (Workload w : {Workload::free_flight, Workload::dense_bed})
    for (std::size_t n : sizes)
      for (int threads : {1, 2}) {
        const Case c{w, n, threads};
        const std::string tail = "/n:" + std::to_string(n) + "/threads:" + std::to_string(threads);
        for (Control control : {Control::fixed, Control::doubling})
          for (Method method : {Method::verlet, Method::exact}) {
            const int intervals = intervals_per_iteration(n, control, method);
            const std::string name = std::string("interval/") + workload_name(w) + "/" +
                                     (control == Control::fixed ? "fixed" : "doubling") + "/" +
                                     (method == Method::verlet ? "verlet" : "exact") + tail;
            benchmark::RegisterBenchmark(name.c_str(), [=](benchmark::State& s) { run_intervals(s, name, c, control, method, intervals); })
                ->Iterations(dem::bench::iterations(n >= 1000000 ? 1 : 3))
                ->UseRealTime()
                ->Unit(benchmark::kMillisecond);
          }
        for (Stage stage : {Stage::grid, Stage::contacts, Stage::forces, Stage::integrate}) {
          const std::string name = std::string("stage/") + workload_name(w) + "/" + stage_name(stage) + tail;
          const auto iterations = static_cast<benchmark::IterationCount>(
              dem::bench::iterations(static_cast<int>(std::max<std::size_t>(5, 2000000 / n))));
          benchmark::RegisterBenchmark(name.c_str(), [=](benchmark::State& s) { run_stage(s, name, c, stage); })
              ->Iterations(iterations)
              ->UseRealTime()
              ->Unit(benchmark::kMicrosecond);
        }
      }
}

}  // namespace

int main(int argc, char** argv) {
  register_all();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
