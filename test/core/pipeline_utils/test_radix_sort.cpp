// radixSortByKey against std::stable_sort.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include "multiview_object_detection/pipeline/utils/radix_sort.h"
#include "multiview_object_detection/pipeline/utils/voxel_key.h"

namespace mvod {

TEST(RadixSort, StableAndInStdSortsOrder) {
  std::mt19937_64 rng(5);
  // Packed voxel keys around the origin (negative fields fill the high bits), many duplicates;
  // full 64-bit keys; keys that share all but their lowest bits; an object's packed keys away from
  // the origin (a few low bits of each field vary); and bits that vary only at both ends.
  std::uniform_int_distribution<int> cell(-300, 300);
  std::uniform_int_distribution<int> near(1000, 1200);
  for (int trial = 0; trial < 5; ++trial) {
    std::vector<std::pair<std::uint64_t, int>> items;
    for (int i = 0; i < 50000; ++i) {
      std::uint64_t key = 0;
      if (trial == 0) {
        key = static_cast<std::uint64_t>(
            packVoxel(Eigen::Vector3i(cell(rng) / 10, cell(rng), cell(rng))));
      } else if (trial == 1) {
        key = rng();
      } else if (trial == 2) {
        key = (std::uint64_t{0xABCDEF} << 40) | (rng() & 0x3FF);
      } else if (trial == 3) {
        key = static_cast<std::uint64_t>(
            packVoxel(Eigen::Vector3i(near(rng), near(rng) / 4, near(rng))));
      } else {
        key = (rng() & 0xF) | ((rng() & 0xF) << 60) | (std::uint64_t{1} << 30);
      }
      items.emplace_back(key, i);
    }
    std::vector<std::pair<std::uint64_t, int>> expected = items;
    std::sort(expected.begin(), expected.end());  // by key, then index: stable for these
    radixSortByKey(&items);
    ASSERT_EQ(items, expected) << "trial " << trial;
  }
  std::vector<std::pair<std::uint64_t, int>> empty;
  radixSortByKey(&empty);
  EXPECT_TRUE(empty.empty());
}

TEST(RadixSort, NonNegativeDoublesInStdSortsOrder) {
  // Angles of a quarter turn with duplicates and zeros, tiny and huge values, subnormals: the
  // bits std::sort gives. With a negative value, -0.0 or an infinity the std::sort fallback.
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> angle(0.0, 1.5707963267948966);
  for (int trial = 0; trial < 5; ++trial) {
    std::vector<double> values;
    for (int i = 0; i < 5000; ++i) {
      double v = angle(rng);
      if (trial == 1) v = std::ldexp(v, static_cast<int>(rng() % 2000) - 1000);
      if (trial == 2 && i % 7 == 0) v = values.empty() ? 0.0 : values[i / 2];  // duplicates
      if (trial == 2 && i % 11 == 0) v = 0.0;
      if (trial == 2 && i % 13 == 0) v = std::numeric_limits<double>::denorm_min() * (i % 5);
      if (trial == 3 && i == 77) v = -0.0;
      if (trial == 4 && i == 99) v = std::numeric_limits<double>::infinity();
      values.push_back(v);
    }
    std::vector<double> expected = values;
    std::sort(expected.begin(), expected.end());
    sortNonNegative(&values);
    ASSERT_EQ(values.size(), expected.size());
    ASSERT_EQ(std::memcmp(values.data(), expected.data(), values.size() * sizeof(double)), 0)
        << "trial " << trial;
  }
}

TEST(RadixSort, KeysInStdSortsOrder) {
  // Packed voxel keys of an object (a few low bits of each field vary), full 64-bit keys, one
  // key repeated, and none.
  std::mt19937_64 rng(9);
  std::uniform_int_distribution<int> near(-60, 60);
  for (int trial = 0; trial < 3; ++trial) {
    std::vector<std::uint64_t> keys;
    for (int i = 0; i < 20000; ++i) {
      keys.push_back(trial == 0   ? static_cast<std::uint64_t>(packVoxel(
                                        Eigen::Vector3i(near(rng), 500 + near(rng), near(rng))))
                     : trial == 1 ? rng()
                                  : std::uint64_t{12345});
    }
    std::vector<std::uint64_t> expected = keys;
    std::sort(expected.begin(), expected.end());
    radixSortKeys(&keys);
    ASSERT_EQ(keys, expected) << "trial " << trial;
  }
  std::vector<std::uint64_t> none;
  radixSortKeys(&none);
  EXPECT_TRUE(none.empty());
}

}  // namespace mvod
