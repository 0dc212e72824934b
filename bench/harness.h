#pragma once
// What every bench program shares, read from the environment once per process:
//
//   DEM_BENCH_SLOWDOWN=<name substring>:<fraction>   (e.g. grid_build_and_pairs/10000:0.25)
//       A hook to prove bench/regress catches a slowdown: every benchmark whose name contains the
//       substring really runs that fraction slower. Each timed iteration is measured with a steady
//       clock and then spins for fraction x its duration inside the timed loop, so real and CPU time
//       both grow. The name is the one Google Benchmark prints without its /iterations:N and
//       /real_time suffixes (family name and arguments). The last ':' separates the fraction, as names
//       hold ':' themselves. Unset: no clock is read.
//   DEM_BENCH_SMOKE=1
//       Each benchmark runs one short iteration (programs shrink their fixed iteration and interval
//       counts through `iterations`), so ctest can run every benchmark and none rots; pass
//       --benchmark_min_time=1e-6 too for the ones that pick their own count.
//
// And BM_Calibration/<threads>, registered in every program that includes this header (so include it
// from one file per program): a fixed amount of plain CPU work per thread (integer hashing and
// floating multiply-adds in registers, no engine code), cut into chunks that 1 or 2 threads take from
// a shared counter, so that, like oneTBB's loops, a thread that is descheduled leaves its chunks to the
// other. bench/regress divides every timing of a program by the median of the calibration with the
// benchmark's thread count from the same run, so a machine that is uniformly slower does not read as
// a regression, and compares /2's real time with /1's CPU time to tell whether the 2 cores were free.
#include <benchmark/benchmark.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include <thread>

namespace dem::bench {

/// True when DEM_BENCH_SMOKE=1: one short iteration per benchmark.
inline bool smoke_run() {
  static const bool smoke = [] {
    const char* value = std::getenv("DEM_BENCH_SMOKE");
    return value != nullptr && std::string_view(value) == "1";
  }();
  return smoke;
}

/// `count` normally, 1 in a smoke run: for fixed iteration and interval counts.
inline int iterations(int count) { return smoke_run() ? 1 : count; }

struct SlowdownSetting {
  std::string pattern;  // name substring; empty: no slowdown
  double fraction = 0;  // added time as a fraction of each iteration's own, >= 0
};

/// DEM_BENCH_SLOWDOWN parsed; a malformed value stops the program with a message (exit code 2).
inline const SlowdownSetting& slowdown_setting() {
  static const SlowdownSetting setting = [] {
    SlowdownSetting s;
    const char* value = std::getenv("DEM_BENCH_SLOWDOWN");
    if (value == nullptr || *value == '\0') return s;
    const std::string text(value);
    const std::size_t colon = text.rfind(':');
    char* end = nullptr;
    const double fraction = colon == std::string::npos ? -1 : std::strtod(text.c_str() + colon + 1, &end);
    if (colon == std::string::npos || colon == 0 || end == text.c_str() + colon + 1 || *end != '\0' ||
        !(fraction >= 0 && fraction <= 100)) {
      std::fprintf(stderr, "DEM_BENCH_SLOWDOWN='%s': expected <name substring>:<fraction>, a fraction in [0, 100]\n",
                   value);
      std::exit(2);
    }
    s.pattern = text.substr(0, colon);
    s.fraction = fraction;
    return s;
  }();
  return setting;
}

/// The slowdown hook of one benchmark: construct it before the timed loop with the benchmark's
/// name, and open `iteration()` as the first statement of the loop body.
class Slowdown {
 public:
  using Clock = std::chrono::steady_clock;

  explicit Slowdown(std::string_view name) {
    const SlowdownSetting& s = slowdown_setting();
    if (!s.pattern.empty() && name.find(s.pattern) != std::string_view::npos) fraction_ = s.fraction;
  }

  /// Times the rest of the loop body (until the end of the enclosing scope) and then spins for
  /// fraction x that time.
  class Iteration {
   public:
    explicit Iteration(double fraction) : fraction_(fraction) {
      if (fraction_ > 0) start_ = Clock::now();
    }
    ~Iteration() {
      if (fraction_ <= 0) return;
      const Clock::time_point end = Clock::now();
      const Clock::time_point until = end + std::chrono::duration_cast<Clock::duration>((end - start_) * fraction_);
      while (Clock::now() < until) {
      }
    }
    Iteration(const Iteration&) = delete;
    Iteration& operator=(const Iteration&) = delete;

   private:
    double fraction_;
    Clock::time_point start_;
  };

  [[nodiscard]] Iteration iteration() const { return Iteration(fraction_); }
  double fraction() const { return fraction_; }

 private:
  double fraction_ = 0;
};

/// The name a benchmark of `family` with one argument prints: "family/arg".
inline std::string bench_name(std::string_view family, std::int64_t arg) {
  return std::string(family) + "/" + std::to_string(arg);
}

namespace detail {

constexpr int calibration_chunks_per_thread = 4;
constexpr int calibration_chunk_length = 1 << 16;  // loop trips, about 0.1 ms on a 2.6 GHz core

// One chunk: a 64-bit xorshift feeding four independent multiply-add chains, all in registers (no
// memory traffic, no library calls, nothing the compiler can fold away).
inline double calibration_chunk(std::uint64_t seed) {
  std::uint64_t x = seed | 1;
  double a = 0, b = 0, c = 0, d = 0;
  for (int i = 0; i < calibration_chunk_length; ++i) {
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    const double u = static_cast<double>(x >> 11) * 0x1.0p-53;  // [0, 1)
    a = a * 0.999999 + u;
    b = b * 0.999998 + u * u;
    c = c * 0.999997 - u;
    d = d * 0.999996 + u * a;
  }
  return a + b + c + d;
}

}  // namespace detail

/// BM_Calibration/<threads>: per iteration, threads x 16 chunks taken from a shared counter by this
/// thread and, for 2 threads, a helper std::thread that lives for the whole repetition and spins
/// between iterations, as oneTBB's workers do between the loops of a step. An iteration ends when
/// every chunk is done, whoever did it: a helper that the machine has descheduled costs what it costs
/// a oneTBB loop (a thread started per iteration, or a join, would time how fast a busy machine
/// schedules a thread instead).
inline void BM_Calibration(benchmark::State& bench) {
  const int threads = static_cast<int>(bench.range(0));
  const Slowdown slowdown(bench_name("BM_Calibration", threads));
  const std::uint64_t chunks = static_cast<std::uint64_t>(threads) * detail::calibration_chunks_per_thread;
  // Iteration r's next chunk c is ticket = r << 32 | c: a thread late from iteration r - 1 takes none.
  std::atomic<std::uint64_t> ticket{0};
  std::atomic<std::uint64_t> done{0};  // chunks of the current iteration completed
  std::atomic<bool> stop{false};
  auto take_chunks = [&](std::uint64_t round) {
    double sum = 0;
    for (std::uint64_t t = ticket.load(std::memory_order_acquire); t >> 32 == round && (t & 0xffffffff) < chunks;) {
      if (!ticket.compare_exchange_weak(t, t + 1, std::memory_order_acq_rel)) continue;
      sum += detail::calibration_chunk(round * chunks + (t & 0xffffffff));
      done.fetch_add(1, std::memory_order_release);
      t = ticket.load(std::memory_order_acquire);
    }
    return sum;
  };
  double helper_sum = 0;
  std::thread helper;
  if (threads == 2)
    helper = std::thread([&] {
      for (std::uint64_t seen = 0;;) {
        const std::uint64_t round = ticket.load(std::memory_order_acquire) >> 32;
        if (round == seen) continue;
        if (stop.load(std::memory_order_acquire)) return;
        seen = round;
        helper_sum += take_chunks(round);
      }
    });
  double sink = 0;
  std::uint64_t round = 0;
  for (auto _ : bench) {
    const auto slow = slowdown.iteration();
    done.store(0, std::memory_order_relaxed);
    ticket.store(++round << 32, std::memory_order_release);
    sink += take_chunks(round);
    while (done.load(std::memory_order_acquire) < chunks) {
    }
  }
  if (helper.joinable()) {
    stop.store(true, std::memory_order_release);
    ticket.store(++round << 32, std::memory_order_release);
    helper.join();
  }
  benchmark::DoNotOptimize(sink + helper_sum);
}

BENCHMARK(BM_Calibration)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace dem::bench
