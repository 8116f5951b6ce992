// The keyframe history in the map: each keyframe's poses, intrinsics, depth (a 16-bit PNG, or raw
// 32-bit floats) and recorded views (cut points and normals as little-endian float32 triples, the
// voxel keys voted against as int64). The arrays are either base64 strings inside the JSON (the
// single-file map of 0.9.x, "keyframe_history") or bytes beside it, [offset, size] in the JSON
// (the map folder's keyframe files, map_folder.h). Private to the io library.
#pragma once

#include <deque>
#include <nlohmann/json.hpp>
#include <string>

#include "multiview_object_detection/pipeline/map/keyframe_history.h"

namespace mvod {
namespace history_json {

// One record. `blobs` null: arrays as base64 strings; else appended to *blobs.
nlohmann::json recordToJson(const KeyframeRecord& record, std::string* blobs);
// Checks every field (poses rigid, points finite and within the map's range, keys valid, depth
// images of the stated size); a malformed record is an error naming the field. `blobs`: the bytes
// the record's [offset, size] fields point into (null: base64 strings only).
Status recordFromJson(const nlohmann::json& value, const std::string& path,
                      const std::string* blobs, KeyframeRecord* record);

// A rigid pose within the map's range: 3 rows of 4 numbers at parent[key].
Status readPose(const nlohmann::json& parent, const std::string& path, const char* key,
                Eigen::Isometry3d* T);
// As the records write them.
nlohmann::json poseToJson(const Eigen::Isometry3d& T);

// The single-file map's "keyframe_history": an array of records in keyframe order, base64 arrays.
nlohmann::json historyToJson(const std::deque<KeyframeRecord>& records);
Status historyFromJson(const nlohmann::json& value, const std::string& path,
                       std::deque<KeyframeRecord>* records);

}  // namespace history_json
}  // namespace mvod
