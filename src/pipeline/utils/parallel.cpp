// oneTBB (libtbb-dev) instead of the std::threads this file started per call before: the threads
// are created once, nested loops share them instead of oversubscribing the cores, and each call
// costs a task rather than a thread start.
#include "multiview_object_detection/pipeline/utils/parallel.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <map>
#include <memory>
#include <mutex>

namespace mvod {
namespace {

// The arena of at most `threads` threads (the caller's included), created on first use and kept
// for the process.
tbb::task_arena& arenaFor(int threads) {
  static std::mutex mutex;
  static std::map<int, std::unique_ptr<tbb::task_arena>> arenas;
  const std::lock_guard<std::mutex> lock(mutex);
  std::unique_ptr<tbb::task_arena>& arena = arenas[threads];
  if (arena == nullptr) arena = std::make_unique<tbb::task_arena>(threads);
  return *arena;
}

// job(i) for each i of [0, count), one task per index (simple_partitioner, grain 1).
template <typename Job>
void forEachIndex(int threads, std::size_t count, const Job& job) {
  arenaFor(threads).execute([&] {
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, count, 1),
        [&](const tbb::blocked_range<std::size_t>& range) {
          for (std::size_t i = range.begin(); i < range.end(); ++i) job(i);
        },
        tbb::simple_partitioner());
  });
}

}  // namespace

void parallelRanges(std::size_t count, int threads, std::size_t min_per_thread,
                    const std::function<void(std::size_t, std::size_t)>& job) {
  const std::size_t by_size = count / std::max<std::size_t>(1, min_per_thread);
  const std::size_t ranges =
      std::max<std::size_t>(1, std::min(by_size, static_cast<std::size_t>(std::max(1, threads))));
  if (ranges <= 1) {
    if (count > 0) job(0, count);
    return;
  }
  const auto begin_of = [count, ranges](std::size_t r) { return count * r / ranges; };
  forEachIndex(threads, ranges, [&](std::size_t r) { job(begin_of(r), begin_of(r + 1)); });
}

void parallelForEach(std::size_t count, int threads, const std::function<void(std::size_t)>& job) {
  if (threads <= 1 || count <= 1) {
    for (std::size_t i = 0; i < count; ++i) job(i);
    return;
  }
  forEachIndex(threads, count, job);
}

void parallelInvoke(int threads, const std::function<void()>& a, const std::function<void()>& b) {
  if (threads <= 1) {
    a();
    b();
    return;
  }
  arenaFor(threads).execute([&] { tbb::parallel_invoke(a, b); });
}

}  // namespace mvod
