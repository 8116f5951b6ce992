// Logging shared by the node's stages: repeats of one problem are printed at most every
// kLogThrottlePeriodS, wherever in the node they come from.
#pragma once

#include <string>

namespace mvod {

constexpr double kLogThrottlePeriodS = 5.0;

// Throttling by message kind rather than by call site: repeats of one problem (differing only in
// stamps and counts) are printed every kLogThrottlePeriodS, while a different problem on the same
// line still shows at once.
bool shouldLog(const std::string& text);
void errorThrottled(const std::string& text);
void warnThrottled(const std::string& text);

}  // namespace mvod
