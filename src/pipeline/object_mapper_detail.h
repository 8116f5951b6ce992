// Helpers shared by ObjectMapper's source files (object_mapper.cpp, object_mapper_fusion.cpp).
#pragma once

#include <cctype>
#include <sstream>
#include <string>

#include "multiview_object_detection/pipeline/object_mapper.h"

namespace mvod {
namespace object_mapper_detail {

inline std::string detectionLabel(size_t index, const Detection2D& detection) {
  std::ostringstream out;
  out << "detection " << index << " ('" << detection.class_name << "' " << detection.score << ")";
  return out.str();
}

// The detection index and problem of a warning made with detectionLabel ("<frame>: detection 4
// ('cup' 0.5): no valid depth inside the mask" -> 4, "no valid depth inside the mask"); false for
// a warning about no single detection.
inline bool parseDetectionWarning(const std::string& warning, size_t* index, std::string* problem) {
  const std::string key = ": detection ";
  const size_t at = warning.find(key);
  if (at == std::string::npos) return false;
  size_t digits_end = at + key.size();
  while (digits_end < warning.size() &&
         std::isdigit(static_cast<unsigned char>(warning[digits_end])))
    ++digits_end;
  if (digits_end == at + key.size() || warning.compare(digits_end, 3, " ('") != 0) return false;
  const size_t end_of_label = warning.find("): ", digits_end);
  if (end_of_label == std::string::npos) return false;
  *index = std::stoul(warning.substr(at + key.size(), digits_end - at - key.size()));
  *problem = warning.substr(end_of_label + 3);
  return true;
}

// The single-view stages' times (filter, LCCP, box) of `from` added to *to: summed over
// detections (CPU time where they ran in parallel).
inline void addStageTimes(const StageTimes& from, StageTimes* to) {
  to->filter_ms += from.filter_ms;
  to->lccp_ms += from.lccp_ms;
  to->manhattan_ms += from.manhattan_ms;
}

}  // namespace object_mapper_detail
}  // namespace mvod
