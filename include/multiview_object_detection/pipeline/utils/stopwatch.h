// Stage timing: milliseconds on the steady clock since a start point (the keyframe reports' and
// /diagnostics' stage times).
#pragma once

#include <chrono>

namespace mvod {

using StopwatchClock = std::chrono::steady_clock;

inline double msSince(StopwatchClock::time_point start) {
  return std::chrono::duration<double, std::milli>(StopwatchClock::now() - start).count();
}

}  // namespace mvod
