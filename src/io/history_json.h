// The keyframe history in the map file ("keyframe_history"): each keyframe's poses, intrinsics,
// depth (a 16-bit PNG, or raw 32-bit floats, base64) and recorded views (cut points and normals
// as little-endian float32 triples, the voxel keys voted against as int64, base64), so that a map
// loaded tomorrow still follows the SLAM's corrections. Private to the io library.
#pragma once

#include <deque>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <unordered_map>

#include "multiview_object_detection/pipeline/map/keyframe_history.h"

namespace mvod {
namespace history_json {

// Encodings from earlier saves of one map: a keyframe's depth image and its cuts never change once
// recorded (shared, immutable data), so a map saved again encodes only what is new. Keyed by the
// data's address; each entry holds a reference to its data, so no address is reused while cached.
// What a save did not use is dropped after it.
struct EncodingCache {
  struct Depth {
    cv::Mat depth;  // keeps the address alive
    nlohmann::json encoded;
    bool used = false;
  };
  struct Cut {
    std::shared_ptr<const RecordedCut> cut;  // keeps the address alive
    nlohmann::json cut_points, normals, outside;
    bool used = false;
  };
  std::unordered_map<const void*, Depth> depths;
  std::unordered_map<const void*, Cut> cuts;
  void dropUnused();
};

// `cache` (may be null): reused and updated.
nlohmann::json historyToJson(const std::deque<KeyframeRecord>& records,
                             EncodingCache* cache = nullptr);
// Checks every field (poses rigid, points finite and within the map's range, keys valid, depth
// images of the stated size); a malformed history is an error naming the field.
Status historyFromJson(const nlohmann::json& value, const std::string& path,
                       std::deque<KeyframeRecord>* records);

}  // namespace history_json
}  // namespace mvod
