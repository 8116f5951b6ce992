#include "offline_detection_warnings.h"

#include <algorithm>
#include <utility>
#include <vector>

namespace offline_detection {
namespace {

bool has(const std::string& text, const char* word) { return text.find(word) != std::string::npos; }

}  // namespace

std::string plainReason(const std::string& warning) {
  // First match wins: the more specific phrases come first.
  static const std::vector<std::pair<const char*, const char*>> kReasons = {
      {"waiting for gravity", "keyframe skipped: no floor seen yet (gravity unknown)"},
      {"sensor or SLAM fault", "keyframe taken for a sensor or SLAM fault"},
      {"not a probability", "detection's score outside [0, 1]"},
      {"under min_probability", "score under min_probability"},
      {"unknown class", "detection's class is not a COCO class"},
      {"no valid depth", "no depth inside its mask"},
      {"covers the whole image", "its box covers the whole image"},
      {"running past", "only a wall, floor or table top in its box"},
      {"lies on the floor", "only floor inside its mask"},
      {"nothing left below", "only floor inside its mask"},
      {"no object in the cut", "no object segment in its box"},
      {"segment", "no object segment in its box"},
      {"supervoxel", "no object segment in its box"},
      {"no box", "no box fitted to its points"},
      {"points", "too few points after filtering"},
      {"cannot write", "an output file could not be written"},
  };
  for (const auto& [phrase, reason] : kReasons) {
    if (has(warning, phrase)) return reason;
  }
  return "other (see --verbose)";
}

std::string describeTally(const WarningTally& tally) {
  std::vector<std::pair<int, std::string>> sorted;
  for (const auto& [reason, count] : tally) sorted.emplace_back(count, reason);
  std::stable_sort(sorted.begin(), sorted.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  std::string text;
  for (const auto& [count, reason] : sorted) {
    if (!text.empty()) text += "; ";
    text += std::to_string(count) + " " + reason;
  }
  return text;
}

}  // namespace offline_detection
