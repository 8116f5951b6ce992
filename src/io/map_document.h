// The map's JSON document as a value: what objectsToJson writes and objectsFromJson reads, for
// the map folder (map_folder.cpp), whose map.json adds the list of keyframe files. Private to the
// io library.
#pragma once

#include <deque>
#include <nlohmann/json.hpp>
#include <vector>

#include "multiview_object_detection/io/json_io.h"

namespace mvod {
namespace map_document {

nlohmann::json toJson(const std::vector<MapObject>& objects, const MapSummary& summary,
                      bool include_clouds);
// The objects and the summary of `doc`, and the single-file history ("keyframe_history") if any.
Status fromJson(const nlohmann::json& doc, std::vector<MapObject>* objects, MapSummary* summary,
                std::deque<KeyframeRecord>* history);
// `text` parsed; an error gives the byte position only (the parser's message quotes the bytes).
Status parse(const std::string& text, const std::string& name, nlohmann::json* doc);
// `doc` as the map file writes it: compact with clouds, indented for people without.
std::string dump(const nlohmann::json& doc, bool compact);

}  // namespace map_document
}  // namespace mvod
