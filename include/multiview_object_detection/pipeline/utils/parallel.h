// The pipeline's threads: loops and pairs of jobs on one pool of threads created once per process
// (oneTBB: one task arena per thread count, its threads from TBB's one pool), not threads started
// per call. `threads` is the most threads a call uses, the caller's included; 1 runs everything on
// the caller's thread, in order, without the pool. Calls may nest (a job may itself run a loop):
// a thread that waits runs other jobs meanwhile.
#pragma once

#include <cstddef>
#include <functional>

namespace mvod {

// Runs job(begin, end) over [0, count) split into contiguous ranges, on up to `threads` threads,
// never with fewer than min_per_thread items per range. The split depends on count, threads and
// min_per_thread only: min(threads, count / min_per_thread) ranges of equal size (at least one),
// whichever thread runs them. For loops whose iterations are independent.
void parallelRanges(std::size_t count, int threads, std::size_t min_per_thread,
                    const std::function<void(std::size_t, std::size_t)>& job);

// Runs job(i) for each i in [0, count) on up to `threads` threads, each index a task of its own,
// lower indices started first: for jobs of very different sizes, given largest first. The jobs
// must be independent (their result must not depend on the thread that ran them).
void parallelForEach(std::size_t count, int threads, const std::function<void(std::size_t)>& job);

// Runs a() and b() on up to `threads` threads (the caller's included), at the same time when a
// thread of the pool is free; returns when both are done. threads <= 1: a(), then b().
void parallelInvoke(int threads, const std::function<void()>& a, const std::function<void()>& b);

}  // namespace mvod
