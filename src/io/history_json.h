// The keyframe history in the map file ("keyframe_history"): each keyframe's poses, intrinsics,
// depth (a 16-bit PNG, or raw 32-bit floats, base64) and recorded views (cut points and normals
// as little-endian float32 triples, the voxel keys voted against as int64, base64), so that a map
// loaded tomorrow still follows the SLAM's corrections. Private to the io library.
#pragma once

#include <deque>
#include <nlohmann/json.hpp>
#include <string>

#include "multiview_object_detection/pipeline/map/keyframe_history.h"

namespace mvod {
namespace history_json {

nlohmann::json historyToJson(const std::deque<KeyframeRecord>& records);
// Checks every field (poses rigid, points finite and within the map's range, keys valid, depth
// images of the stated size); a malformed history is an error naming the field.
Status historyFromJson(const nlohmann::json& value, const std::string& path,
                       std::deque<KeyframeRecord>* records);

}  // namespace history_json
}  // namespace mvod
