#include "multiview_object_detection/io/json_io.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "history_json.h"
#include "json_fields.h"
#include "map_document.h"
#include "multiview_object_detection/pipeline/map/output_frame.h"
#include "multiview_object_detection/pipeline/types/map_limits.h"
#include "multiview_object_detection/pipeline/utils/voxel_key.h"
#include "object_json.h"

namespace mvod {
namespace {

using nlohmann::json;

using namespace json_fields;  // NOLINT: the map's field readers

json stageTimesToJson(const StageTimes& t) {
  return json{
      {"extraction", t.extraction_ms}, {"filter", t.filter_ms}, {"lccp", t.lccp_ms},
      {"manhattan", t.manhattan_ms},   {"fusion", t.fusion_ms}, {"existence", t.existence_ms},
      {"refinement", t.refinement_ms}, {"total", t.total_ms}};
}

// "frame": {"name": "gravity_aligned", "T_world_frame": 4 rows of 4}: the frame the objects are in.
json frameToJson(const Eigen::Isometry3d& T_W_O) {
  json rows = json::array();
  const Eigen::Matrix4d m = T_W_O.matrix();
  for (int r = 0; r < 4; ++r) rows.push_back(json::array({m(r, 0), m(r, 1), m(r, 2), m(r, 3)}));
  return {{"name", "gravity_aligned"}, {"T_world_frame", rows}};
}

Status frameFromJson(const json& frame, Eigen::Isometry3d* T_W_O) {
  if (!frame.is_object()) return fieldError("frame", "expected an object");
  const auto rows = frame.find("T_world_frame");
  if (rows == frame.end() || !rows->is_array() || rows->size() != 4) {
    return fieldError("frame.T_world_frame", "expected 4 rows of 4 numbers");
  }
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    const json& row = (*rows)[r];
    if (!row.is_array() || row.size() != 4) {
      return fieldError("frame.T_world_frame", "expected 4 rows of 4 numbers");
    }
    for (int c = 0; c < 4; ++c) {
      if (!row[c].is_number()) return fieldError("frame.T_world_frame", "expected numbers");
      m(r, c) = row[c].get<double>();
    }
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.matrix().topRows<3>() = m.topRows<3>();
  if (!m.allFinite() || !m.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1), 1e-9) ||
      !isValidPose(T, 1e-6) || T.translation().cwiseAbs().maxCoeff() > kMapCoordinateLimitM) {
    return fieldError("frame.T_world_frame", "not a rigid transform within the map's limits");
  }
  *T_W_O = T;
  return Status::Ok();
}

// "removed": the refinement's and the existence evidence's removals.
Status readRemoved(const json& doc, MapSummary* summary) {
  Status status;
  const json* removed = nullptr;
  if (!(status = member(doc, "", "removed", &removed))) return status;
  if (!removed->is_object()) return fieldError("removed", "expected an object");
  if (!(status = readInt(*removed, "removed.", "atypical", 0, &summary->removed_atypical))) {
    return status;
  }
  if (!(status =
            readInt(*removed, "removed.", "intersecting", 0, &summary->removed_intersecting))) {
    return status;
  }
  if (removed->contains("gone") &&  // maps of 0.9.0 and before have none
      !(status = readInt(*removed, "removed.", "gone", 0, &summary->removed_gone))) {
    return status;
  }
  return Status::Ok();
}

// "stage_ms": the medians of the stage times.
Status readStageTimes(const json& doc, MapSummary* summary) {
  Status status;
  const json* stages = nullptr;
  if (!(status = member(doc, "", "stage_ms", &stages))) return status;
  if (!stages->is_object()) return fieldError("stage_ms", "expected an object");
  StageTimes& t = summary->stage_ms_median;
  const std::pair<const char*, double*> stage_fields[] = {{"extraction", &t.extraction_ms},
                                                          {"filter", &t.filter_ms},
                                                          {"lccp", &t.lccp_ms},
                                                          {"manhattan", &t.manhattan_ms},
                                                          {"fusion", &t.fusion_ms},
                                                          {"refinement", &t.refinement_ms},
                                                          {"total", &t.total_ms}};
  for (const auto& field : stage_fields) {
    if (!(status = readNumber(*stages, "stage_ms.", field.first, field.second))) return status;
    if (*field.second < 0.0) return fieldError(std::string("stage_ms.") + field.first, "negative");
  }
  if (stages->contains("existence")) {  // maps of 0.9.0 and before have none
    if (!(status = readNumber(*stages, "stage_ms.", "existence", &t.existence_ms))) return status;
    if (t.existence_ms < 0.0) return fieldError("stage_ms.existence", "negative");
  }
  return Status::Ok();
}

// "counts" (optional): the detections' way through the pipeline.
Status readCounts(const json& doc, MapSummary* summary) {
  Status status;
  if (doc.contains("counts")) {
    const json& counts = doc["counts"];
    if (!counts.is_object()) return fieldError("counts", "expected an object");
    MapSummary::Counts& c = summary->counts;
    const std::pair<const char*, int*> count_fields[] = {
        {"detections", &c.detections}, {"above_threshold", &c.above_threshold},
        {"with_box", &c.with_box},     {"inserted", &c.inserted},
        {"fused", &c.fused},           {"before_refinement", &c.before_refinement}};
    for (const auto& field : count_fields) {
      if (!(status = readInt(counts, "counts.", field.first, 0, field.second))) return status;
    }
  }
  return Status::Ok();
}

}  // namespace

std::vector<MapObject> databaseObjects(const ObjectDatabase& database) {
  std::vector<MapObject> objects;
  objects.reserve(database.size());
  for (const auto& entry : database.objects()) objects.push_back(entry.second);
  return objects;
}

namespace map_document {

json toJson(const std::vector<MapObject>& objects, const MapSummary& summary, bool include_clouds) {
  json doc;
  doc["frames"] = summary.frames;
  doc["keyframes"] = summary.keyframes;
  doc["gravity_down"] = vectorToJson(summary.gravity_down_W);
  if (std::isfinite(summary.floor_height_m)) doc["floor_height_m"] = summary.floor_height_m;
  std::vector<MapObject> objects_O;
  if (summary.objects_in_gravity_frame) {
    objects_O = objectsInFrame(objects, summary.T_W_O.inverse(), include_clouds);
    doc["frame"] = frameToJson(summary.T_W_O);
  }
  json list = json::array();
  const std::vector<MapObject>& written = summary.objects_in_gravity_frame ? objects_O : objects;
  for (size_t i = 0; i < written.size(); ++i) {
    json entry = object_json::objectToJson(written[i], include_clouds);
    // The object's fused points, also where the file leaves them out (objectsInFrame moves
    // clouds only when they are written).
    entry["num_points"] = objects[i].points_W.size();
    list.push_back(std::move(entry));
  }
  doc["objects"] = std::move(list);
  doc["removed"] = {{"atypical", summary.removed_atypical},
                    {"intersecting", summary.removed_intersecting},
                    {"gone", summary.removed_gone}};
  doc["stage_ms"] = stageTimesToJson(summary.stage_ms_median);
  const MapSummary::Counts& c = summary.counts;
  doc["counts"] = {{"detections", c.detections}, {"above_threshold", c.above_threshold},
                   {"with_box", c.with_box},     {"inserted", c.inserted},
                   {"fused", c.fused},           {"before_refinement", c.before_refinement}};
  return doc;
}

std::string dump(const json& doc, bool compact) {
  // Names come from detectors: bytes that are not UTF-8 are replaced rather than failing the save.
  return doc.dump(compact ? -1 : 2, ' ', false, json::error_handler_t::replace) + "\n";
}

Status parse(const std::string& text, const std::string& name, json* doc) {
  try {
    *doc = json::parse(text);
  } catch (const json::parse_error& e) {
    // The position only: the parser's message quotes the bytes it read, which may be anything
    // (a file that is not a map at all).
    return Status::Error(name + ": not valid JSON (parse error at byte " + std::to_string(e.byte) +
                         ")");
  } catch (const json::exception& e) {
    return Status::Error(name + ": not valid JSON (error " + std::to_string(e.id) + ")");
  }
  if (!doc->is_object()) return fieldError("(document)", "expected a JSON object");
  return Status::Ok();
}

Status fromJson(const json& doc, std::vector<MapObject>* objects, MapSummary* summary,
                std::deque<KeyframeRecord>* history) {
  MapSummary parsed;
  Status status;
  if (!(status = readInt(doc, "", "frames", 0, &parsed.frames))) return status;
  if (!(status = readInt(doc, "", "keyframes", 0, &parsed.keyframes))) return status;
  if (!(status = readVector3(doc, "", "gravity_down", &parsed.gravity_down_W))) return status;
  if (doc.contains("floor_height_m")) {  // maps of 0.9.x and before have none
    if (!(status = readNumber(doc, "", "floor_height_m", &parsed.floor_height_m))) return status;
    if (std::abs(parsed.floor_height_m) > kMapCoordinateLimitM) {
      return fieldError("floor_height_m", "beyond the map's limits");
    }
  }

  if (!(status = readRemoved(doc, &parsed))) return status;
  if (!(status = readStageTimes(doc, &parsed))) return status;
  if (!(status = readCounts(doc, &parsed))) return status;

  if (doc.contains("frame")) {  // the offline tools' files (maps of 0.9.x and before have none)
    if (!(status = frameFromJson(doc["frame"], &parsed.T_W_O))) return status;
    parsed.objects_in_gravity_frame = true;
  }

  const json* list = nullptr;
  if (!(status = member(doc, "", "objects", &list))) return status;
  if (!list->is_array()) return fieldError("objects", "expected an array");
  std::vector<MapObject> parsed_objects;
  std::set<int> ids;
  for (size_t i = 0; i < list->size(); ++i) {
    MapObject object;
    const std::string path = "objects[" + std::to_string(i) + "]";
    if (!(status = object_json::objectFromJson((*list)[i], path, &object))) return status;
    if (!ids.insert(object.id).second) {
      return fieldError(path + ".id", "duplicate id " + std::to_string(object.id));
    }
    if (parsed.objects_in_gravity_frame &&
        (object.evidence_voxel_size_m > 0.0 || object.free_space_cell_m > 0.0)) {
      return fieldError(path,
                        "evidence or free space grids in a file written in the gravity-aligned "
                        "frame (they cannot be rotated)");
    }
    parsed_objects.push_back(std::move(object));
  }
  if (parsed.objects_in_gravity_frame) {
    parsed_objects = objectsInFrame(parsed_objects, parsed.T_W_O, true);  // back into the world
  }

  // The keyframe history (optional: a map without it loads, but cannot follow corrections).
  std::deque<KeyframeRecord> parsed_history;
  const auto history_it = doc.find("keyframe_history");
  if (history_it != doc.end()) {
    status = history_json::historyFromJson(*history_it, "keyframe_history", &parsed_history);
    if (!status) return status;
  }

  if (objects != nullptr) *objects = std::move(parsed_objects);
  if (summary != nullptr) *summary = parsed;
  if (history != nullptr) *history = std::move(parsed_history);
  return Status::Ok();
}

}  // namespace map_document

std::string objectsToJson(const std::vector<MapObject>& objects, const MapSummary& summary,
                          bool include_clouds, const std::deque<KeyframeRecord>* history) {
  json doc = map_document::toJson(objects, summary, include_clouds);
  if (history != nullptr && !history->empty()) {
    doc["keyframe_history"] = history_json::historyToJson(*history);
  }
  // With clouds the document is large: compact. Without, indented for people to read.
  return map_document::dump(doc, include_clouds);
}

Status objectsFromJson(const std::string& text, std::vector<MapObject>* objects,
                       MapSummary* summary, std::deque<KeyframeRecord>* history) {
  json doc;
  const Status parsed = map_document::parse(text, "objects.json", &doc);
  if (!parsed) return parsed;
  return map_document::fromJson(doc, objects, summary, history);
}

}  // namespace mvod
