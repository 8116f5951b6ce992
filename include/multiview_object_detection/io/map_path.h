// Where ~save_map and ~load_map may read and write: a map directory that relative paths resolve
// into and that absolute paths must lie in, so a service call cannot overwrite or read any file the
// node's user can reach (allow_any_path lifts this for those who want it).
#pragma once

#include <string>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {

struct MapPathPolicy {
  std::string directory;        // absolute; empty = defaultMapDirectory()
  bool allow_any_path = false;  // absolute paths anywhere
};

// $ROS_HOME/multiview_object_detection/maps, else ~/.ros/multiview_object_detection/maps (else
// /tmp/... when neither is set).
std::string defaultMapDirectory();

// The file `path` names under `policy`: a relative path is taken in the map directory; `..` and
// the folders' links are resolved before the check, so neither leads out of it. A symbolic link at
// the file's own name is refused (naming its target), whether or not it leads out: the node never
// writes, replaces or moves a file through a link. for_writing creates the map
// directory when the path lies in it. An empty path, one that ends in '/', or one outside the
// directory is an error naming the directory.
Status resolveMapPath(const std::string& path, const MapPathPolicy& policy, bool for_writing,
                      std::string* resolved);

// Creates the map directory if missing and proves it writable by creating and removing a file in
// it. The error names the directory and the reason (not absolute, a file, permission, read-only).
Status prepareMapDirectory(const MapPathPolicy& policy);

}  // namespace mvod
