// One map object in the map file (an entry of "objects"): identity, box, seen extents, class
// scores, existence and, with clouds, its points, evidence grid and free-space cells. Every field
// read is checked (type, range, the map's limits). Private to the io library.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "multiview_object_detection/pipeline/map/object_database.h"
#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {
namespace object_json {

// The object as written; its clouds and grids only with include_clouds.
nlohmann::json objectToJson(const MapObject& object, bool include_clouds);

// The object at `path` (for messages, "objects[3]"); *out is unchanged on an error.
Status objectFromJson(const nlohmann::json& value, const std::string& path, MapObject* out);

}  // namespace object_json
}  // namespace mvod
