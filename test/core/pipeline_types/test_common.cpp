// Helpers of common.h.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {
namespace {

std::uint64_t bitsOf(double x) {
  std::uint64_t bits;
  std::memcpy(&bits, &x, sizeof(bits));
  return bits;
}

}  // namespace

TEST(FmodSmall, SameBitsAsStdFmod) {
  // Random angles within and beyond 16 divisors, exact multiples and their neighbours, signed
  // zeros, tiny values, infinities and NaN: the same bits as std::fmod (NaN: a NaN).
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> uniform(-40.0, 40.0);
  const double half_pi = 1.5707963267948966;
  for (const double y : {half_pi, 1.0, 0.1, 3e-5, 7.25}) {
    std::vector<double> xs = {0.0,
                              -0.0,
                              1e-300,
                              -1e-300,
                              std::numeric_limits<double>::infinity(),
                              -std::numeric_limits<double>::infinity(),
                              std::numeric_limits<double>::quiet_NaN()};
    for (int k = -17; k <= 17; ++k) {
      const double multiple = k * y;
      xs.push_back(multiple);
      xs.push_back(std::nextafter(multiple, 1e9));
      xs.push_back(std::nextafter(multiple, -1e9));
    }
    for (int i = 0; i < 200000; ++i) xs.push_back(uniform(rng) * y / half_pi);
    for (const double x : xs) {
      const double expected = std::fmod(x, y);
      const double got = fmodSmall(x, y);
      if (std::isnan(expected)) {
        EXPECT_TRUE(std::isnan(got)) << x;
      } else {
        ASSERT_EQ(bitsOf(got), bitsOf(expected)) << "fmod(" << x << ", " << y << ")";
      }
    }
  }
}

}  // namespace mvod
