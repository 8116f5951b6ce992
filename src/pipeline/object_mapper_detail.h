// Helpers shared by ObjectMapper's source files (object_mapper.cpp, object_mapper_fusion.cpp).
#pragma once

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

// A warning about one detection (its index in the keyframe's detections): into out->warnings as
// "<label>: detection 4 ('cup' 0.5): <problem>", and, as the first word on that detection, into
// out->drop_reasons[index] (what the overlays and the run summary say of it).
inline void warnDetection(const std::string& label, size_t index, const Detection2D& detection,
                          const std::string& problem, KeyframeReport* out) {
  out->warnings.push_back(label + ": " + detectionLabel(index, detection) + ": " + problem);
  if (index < out->drop_reasons.size() && out->drop_reasons[index].empty()) {
    out->drop_reasons[index] = problem;
  }
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
