#pragma once
// The parallel backend of the whole project (docs/design.md, Determinism), and the small
// helpers the broadphase implementations share. Every loop of the engine and of the broadphase runs
// through here, inside the caller's TaskArena (the World's), so a thread count is set in one place.
//
// Two backends, chosen at configure time: oneTBB (the default), and, when DEM_PARALLEL_STD_THREAD is
// defined (CMake DEM_SANITIZE=thread), a pool of std::threads that ThreadSanitizer can see into
// (Debian's oneTBB is not instrumented). Both split a loop into ranges and give the same results:
// bodies write only the slots they own, reductions are exact and order-free (min, max, OR, integer
// add), and the scan is over integers in blocks whose size ignores the thread count, so no result
// depends on the backend, the split or the thread count.
//
// The std::thread backend: an arena of T threads starts T - 1 workers; a loop is cut into chunks of
// `grain` indices and chunk k runs on participant k mod T (the calling thread is participant 0).
// Loops outside any arena, and loops nested inside a loop body, run on the calling thread alone.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#if DEM_PARALLEL_STD_THREAD
#include <mutex>
#else
#include <tbb/blocked_range.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>
#endif

namespace dem::broadphase {

#if !DEM_PARALLEL_STD_THREAD

/// The threads parallel loops run on: a oneTBB task_arena of a fixed concurrency.
class TaskArena {
 public:
  explicit TaskArena(int threads) : arena_(threads) {}
  int max_concurrency() const { return arena_.max_concurrency(); }
  /// Runs f on the calling thread; the loops it calls run on this arena's threads.
  template <class F>
  decltype(auto) execute(F&& f) {
    return arena_.execute(std::forward<F>(f));
  }
  /// The oneTBB arena itself (for tbb::task_scheduler_observer in tests).
  tbb::task_arena& native() { return arena_; }

  /// Threads available to this process (its affinity mask).
  static int default_concurrency() { return tbb::info::default_concurrency(); }
  /// Concurrency of the arena the calling thread is in.
  static int current_concurrency() { return tbb::this_task_arena::max_concurrency(); }

 private:
  tbb::task_arena arena_;
};

/// Calls body(begin, end) on disjoint sub-ranges covering [0, n), in parallel. The body must write only
/// slots owned by indices of its own sub-range.
template <class Body>
void parallel_ranges(std::size_t n, std::size_t grain, const Body& body) {
  if (n == 0) return;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain),
                    [&](const tbb::blocked_range<std::size_t>& r) { body(r.begin(), r.end()); });
}

/// Runs f so that a thread waiting in f's own parallel loops takes no task of the loop around it (which
/// could use the same per-thread scratch meanwhile).
template <class F>
void isolated(F&& f) {
  tbb::this_task_arena::isolate(std::forward<F>(f));
}

/// Reduces [0, n) with an exact, order-free combine (min, max, OR, integer add), so any split gives the
/// same answer: range(begin, end, acc) folds a sub-range into acc and returns it; combine(a, b) joins two.
template <class T, class Range, class Combine>
T exact_reduce(std::size_t n, std::size_t grain, T identity, const Range& range, const Combine& combine) {
  if (n <= grain) return range(std::size_t{0}, n, identity);  // one sub-range anyway: no tasks
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, grain), identity,
      [&](const tbb::blocked_range<std::size_t>& r, T acc) { return range(r.begin(), r.end(), acc); }, combine);
}

#else  // DEM_PARALLEL_STD_THREAD

/// The threads parallel loops run on: the calling thread plus max_concurrency() - 1 std::threads,
/// started with the arena and joined when it is destroyed. One loop runs at a time.
class TaskArena {
 public:
  explicit TaskArena(int threads);
  ~TaskArena();
  TaskArena(const TaskArena&) = delete;
  TaskArena& operator=(const TaskArena&) = delete;

  int max_concurrency() const { return threads_; }
  /// Runs f on the calling thread; the loops it calls run on this arena's threads.
  template <class F>
  decltype(auto) execute(F&& f) {
    const Entered entered(this);
    return std::forward<F>(f)();
  }
  /// Participants (the calling thread counts as one) that have run a chunk of a loop so far.
  int threads_used() const;

  /// Threads available to this process (its affinity mask).
  static int default_concurrency();
  /// Concurrency of the arena the calling thread is in (1 outside any arena and inside a loop body).
  static int current_concurrency();

  // For parallel_ranges. The arena a loop called on this thread may use: null outside any arena,
  // inside a loop body, or for one thread.
  static TaskArena* joinable();
  using Chunk = void (*)(const void* context, std::size_t chunk);
  /// Runs chunk(context, k) for k in [0, chunk_count), k on participant k mod max_concurrency();
  /// returns when all have run, rethrowing the first exception a chunk threw.
  void run(std::size_t chunk_count, Chunk chunk, const void* context);

 private:
  struct Entered {
    explicit Entered(TaskArena* arena);
    ~Entered();
    Entered(const Entered&) = delete;
    Entered& operator=(const Entered&) = delete;
    TaskArena* previous;
  };
  struct Pool;
  void work(std::size_t participant);

  int threads_;
  std::unique_ptr<Pool> pool_;
};

/// Calls body(begin, end) on disjoint sub-ranges covering [0, n), in parallel. The body must write only
/// slots owned by indices of its own sub-range.
template <class Body>
void parallel_ranges(std::size_t n, std::size_t grain, const Body& body) {
  if (n == 0) return;
  grain = std::max<std::size_t>(grain, 1);
  const std::size_t chunk_count = (n + grain - 1) / grain;
  TaskArena* arena = TaskArena::joinable();
  if (chunk_count == 1 || arena == nullptr) {
    for (std::size_t begin = 0; begin < n; begin += grain) body(begin, std::min(n, begin + grain));
    return;
  }
  struct Context {
    const Body* body;
    std::size_t n, grain;
  };
  const Context context{&body, n, grain};
  arena->run(
      chunk_count,
      [](const void* c, std::size_t k) {
        const Context& x = *static_cast<const Context*>(c);
        (*x.body)(k * x.grain, std::min(x.n, (k + 1) * x.grain));
      },
      &context);
}

/// Runs f: loops nested in a loop body run on the calling thread alone, so nothing else can interleave.
template <class F>
void isolated(F&& f) {
  std::forward<F>(f)();
}

/// Reduces [0, n) with an exact, order-free combine (min, max, OR, integer add), so any split gives the
/// same answer: range(begin, end, acc) folds a sub-range into acc and returns it; combine(a, b) joins two.
template <class T, class Range, class Combine>
T exact_reduce(std::size_t n, std::size_t grain, T identity, const Range& range, const Combine& combine) {
  if (n <= grain) return range(std::size_t{0}, n, identity);  // one sub-range anyway: no threads
  // Each sub-range folds on its own, then joins the total under a lock: the combine is order-free, and
  // nothing is allocated (the broadphase allocates nothing after warm-up).
  std::mutex mutex;
  T total = identity;
  parallel_ranges(n, grain, [&](std::size_t begin, std::size_t end) {
    const T part = range(begin, end, identity);
    const std::lock_guard<std::mutex> lock(mutex);
    total = combine(total, part);
  });
  return total;
}

#endif  // DEM_PARALLEL_STD_THREAD

namespace detail {

/// Replaces values by their inclusive prefix sums and returns the total (64-bit, so the caller can see
/// that it overflowed 32 bits). Blocks of fixed size: sum each block in parallel, scan the block sums
/// serially, then add the block offsets in parallel. `block_sums` is scratch, reused across calls.
inline std::uint64_t inclusive_scan_in_place(std::span<std::uint32_t> values, std::vector<std::uint64_t>& block_sums) {
  constexpr std::size_t block = 16384;
  const std::size_t n = values.size();
  const std::size_t block_count = (n + block - 1) / block;
  block_sums.resize(block_count + 1);
  parallel_ranges(block_count, 1, [&](std::size_t b0, std::size_t b1) {
    for (std::size_t b = b0; b < b1; ++b) {
      std::uint64_t sum = 0;
      for (std::size_t i = b * block; i < std::min(n, (b + 1) * block); ++i) sum += values[i];
      block_sums[b] = sum;
    }
  });
  std::uint64_t running = 0;
  for (std::size_t b = 0; b < block_count; ++b) {
    const std::uint64_t sum = block_sums[b];
    block_sums[b] = running;
    running += sum;
  }
  parallel_ranges(block_count, 1, [&](std::size_t b0, std::size_t b1) {
    for (std::size_t b = b0; b < b1; ++b) {
      std::uint64_t sum = block_sums[b];
      for (std::size_t i = b * block; i < std::min(n, (b + 1) * block); ++i) {
        sum += values[i];
        values[i] = static_cast<std::uint32_t>(sum);
      }
    }
  });
  return running;
}

}  // namespace detail
}  // namespace dem::broadphase
