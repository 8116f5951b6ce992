// objects.json: the object database as JSON, the offline runner's output and the map file format.
#pragma once

#include <deque>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "multiview_object_detection/io/file_io.h"  // the map files are read and written with it
#include "multiview_object_detection/pipeline/map/object_database.h"
#include "multiview_object_detection/pipeline/object_mapper.h"

namespace mvod {

struct MapSummary {
  int frames = 0;
  int keyframes = 0;
  int removed_atypical = 0;
  int removed_intersecting = 0;
  int removed_gone = 0;        // the existence evidence showed them gone (optional in the file)
  StageTimes stage_ms_median;  // medians per keyframe
  // Table 4's counts over the whole run (sums of the KeyframeReports). Optional in the file: maps
  // written without them read as zeros.
  struct Counts {
    int detections = 0;         // 2D detections the detector reported
    int above_threshold = 0;    // probability >= lambda (Eq. 5)
    int with_box = 0;           // survived extraction, filters and LCCP, got a box
    int inserted = 0;           // became a new database object
    int fused = 0;              // fused into an existing object (Eq. 6)
    int before_refinement = 0;  // database size before Sec. 3.5
  } counts;
  Eigen::Vector3d gravity_down_W = Eigen::Vector3d(0, 0, -1);
  // The floor's height along -gravity_down (m; NaN: none found). Optional in the file: a loaded
  // map keeps the floor, and so the output frame's origin (output_frame.h), it was saved with.
  double floor_height_m = std::numeric_limits<double>::quiet_NaN();
  // The offline tools' files: the objects are written in the gravity-aligned frame O
  // (output_frame.h: z up, the floor at z = 0) with T_W_O, O's pose in the input's world frame,
  // alongside ("frame"). objectsToJson writes them in O when set (without the evidence and free
  // space grids, which cannot rotate); objectsFromJson returns them in the world frame again and
  // sets both fields, so every reader (the node's ~load_map, evaluate) gets world coordinates.
  bool objects_in_gravity_frame = false;
  Eigen::Isometry3d T_W_O = Eigen::Isometry3d::Identity();
};

// {"frames", "keyframes", "gravity_down", "objects": [{"id", "class_name", "class_id",
// "probability",
//  "observations", "center", "size", "rotation" (3x3, columns = box axes), "yaw", "num_points",
//  ...}], "removed": {"atypical", "intersecting", "gone"}, "stage_ms": {...}, "counts": {...}}.
//  With include_clouds the fused and segmented
// clouds are stored too (a map that can be reloaded and fused into). With a history, its keyframes
// too ("keyframe_history", base64 inside the JSON): the single-file map of 0.9.x, still read; the
// node writes its maps as folders (map_folder.h), and the offline tools' objects.json has no
// history.
std::string objectsToJson(const std::vector<MapObject>& objects, const MapSummary& summary,
                          bool include_clouds, const std::deque<KeyframeRecord>* history = nullptr);
// Parses what objectsToJson wrote; a malformed document is an error naming the field, and leaves
// the outputs untouched. history (optional): the keyframe history, empty when the file has none.
Status objectsFromJson(const std::string& text, std::vector<MapObject>* objects,
                       MapSummary* summary, std::deque<KeyframeRecord>* history = nullptr);

std::vector<MapObject> databaseObjects(const ObjectDatabase& database);

}  // namespace mvod
