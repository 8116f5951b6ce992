// parallelRanges, parallelForEach and parallelInvoke: every index once, the same ranges for any
// thread count, nested calls.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <mutex>
#include <utility>
#include <vector>

#include "multiview_object_detection/pipeline/utils/parallel.h"

namespace mvod {
namespace {

std::vector<std::pair<std::size_t, std::size_t>> rangesOf(std::size_t count, int threads,
                                                          std::size_t min_per_thread) {
  std::mutex mutex;
  std::vector<std::pair<std::size_t, std::size_t>> ranges;
  parallelRanges(count, threads, min_per_thread, [&](std::size_t first, std::size_t last) {
    const std::lock_guard<std::mutex> lock(mutex);
    ranges.emplace_back(first, last);
  });
  std::sort(ranges.begin(), ranges.end());
  return ranges;
}

TEST(Parallel, RangesCoverEveryIndexOnceInEqualContiguousParts) {
  for (const int threads : {1, 2, 3, 8}) {
    const std::vector<std::pair<std::size_t, std::size_t>> ranges = rangesOf(1000, threads, 100);
    ASSERT_EQ(ranges.size(), static_cast<std::size_t>(threads)) << threads;
    std::size_t next = 0;
    for (std::size_t r = 0; r < ranges.size(); ++r) {
      EXPECT_EQ(ranges[r].first, next);
      EXPECT_EQ(ranges[r].second, 1000 * (r + 1) / ranges.size());
      next = ranges[r].second;
    }
    EXPECT_EQ(next, 1000u);
  }
  // Never fewer than min_per_thread a range; nothing for no items.
  EXPECT_EQ(rangesOf(250, 8, 100).size(), 2u);
  EXPECT_EQ(rangesOf(50, 8, 100).size(), 1u);
  EXPECT_TRUE(rangesOf(0, 8, 100).empty());
}

TEST(Parallel, ForEachRunsEveryIndexOnce) {
  for (const int threads : {1, 2, 4}) {
    std::vector<std::atomic<int>> runs(500);
    parallelForEach(runs.size(), threads, [&](std::size_t i) { ++runs[i]; });
    for (std::size_t i = 0; i < runs.size(); ++i) EXPECT_EQ(runs[i].load(), 1) << i;
  }
}

TEST(Parallel, NestedCallsAndInvokeComplete) {
  // A loop in each job of a loop, as a detection's filter runs inside the keyframe's loop.
  std::vector<std::vector<int>> sums(16, std::vector<int>(8, 0));
  parallelForEach(sums.size(), 4, [&](std::size_t i) {
    parallelRanges(8, 4, 1, [&](std::size_t first, std::size_t last) {
      for (std::size_t k = first; k < last; ++k) sums[i][k] = static_cast<int>(i + k);
    });
  });
  for (std::size_t i = 0; i < sums.size(); ++i) {
    for (std::size_t k = 0; k < 8; ++k) EXPECT_EQ(sums[i][k], static_cast<int>(i + k));
  }
  for (const int threads : {1, 2}) {
    int a = 0, b = 0;
    parallelInvoke(
        threads, [&] { a = 1; }, [&] { b = 2; });
    EXPECT_EQ(a + b, 3);
  }
}

}  // namespace
}  // namespace mvod
