// offline_detection's warnings in plain words: each dropped detection or skipped keyframe gets a
// reason a user can act on, counted for the run's summary; the full line only with --verbose.
#pragma once

#include <map>
#include <string>

namespace offline_detection {

// The plain reason of a warning line of the mapper or the detector ("only a wall, floor or table
// top in its box" for "no object in the cut: only surfaces running past ...").
std::string plainReason(const std::string& warning);

// Reason -> count, in the order of the reasons' names.
using WarningTally = std::map<std::string, int>;

// "18 only a wall, floor or table top in its box; 11 no object segment in its box" (most first);
// "" when there was none.
std::string describeTally(const WarningTally& tally);

}  // namespace offline_detection
