// splitmix64: a tiny portable random generator. A seed gives the same numbers on every platform
// and standard library (std::*_distribution are implementation defined), so the synthetic scenes
// and the simulated detector are reproducible everywhere.
#pragma once

#include <cmath>
#include <cstdint>

namespace mvod {

class SplitMix64 {
 public:
  explicit SplitMix64(uint64_t state) : state_(state) {}
  uint64_t next() {
    uint64_t z = (state_ += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1), 53 random bits.
  double uniform() { return static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0); }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  bool bernoulli(double probability) { return uniform() < probability; }
  // Integer in [lo, hi]; the modulo bias is below 1e-15 for small ranges.
  int uniformInt(int lo, int hi) {
    return lo + static_cast<int>(next() % static_cast<uint64_t>(hi - lo + 1));
  }
  // Standard normal by Box-Muller (two uniforms, exact tails).
  double gaussian() {
    const double u1 = 1.0 - uniform();  // (0, 1]
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * 3.14159265358979323846 * u2);
  }
  // Normal by Irwin-Hall: the sum of 12 uniforms (mean 6, variance 1), always 12 draws, bounded
  // at +-6 sigma.
  double irwinHallNormal(double mean, double stddev) {
    double sum = 0.0;
    for (int i = 0; i < 12; ++i) sum += uniform();
    return mean + stddev * (sum - 6.0);
  }

 private:
  uint64_t state_;
};

// A new seed from a seed and a salt (one splitmix64 step): each use of a seed (a room's layout,
// the camera's wobble, the noise of frame i) draws from its own stream.
inline uint64_t mixSeed(uint64_t a, uint64_t b) {
  SplitMix64 rng(a * 0x2545f4914f6cdd1dULL + b + 0x632be59bd9b4e019ULL);
  return rng.next();
}

}  // namespace mvod
