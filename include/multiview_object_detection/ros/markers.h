// What rviz shows of the map: box edges and labels as markers, the objects' points as one
// coloured PointCloud2, and the colours (per class, per object id). Pure functions, like
// conversions.h.
#pragma once

#include <sensor_msgs/PointCloud2.h>
#include <std_msgs/ColorRGBA.h>
#include <std_msgs/Header.h>
#include <visualization_msgs/MarkerArray.h>

#include <set>
#include <vector>

#include "multiview_object_detection/pipeline/map/object_database.h"

namespace mvod {

// A colour per class (stable between runs) and one per object id.
std_msgs::ColorRGBA classColor(int class_id);
std_msgs::ColorRGBA objectColor(int object_id);

// ns "boxes": LINE_LIST of the 12 box edges coloured by class; ns "labels": TEXT_VIEW_FACING
// "chair #3" over the box (0.12 m high; 0.07 m for objects under 0.5 m), lifted a line where it
// would cross an older neighbour's (label_placement.h);
// ns "label_lines": a thin line from the box top to its label; marker id = object id. Ids in
// *published_ids that are no longer in `objects` get DELETE markers in all three namespaces; on
// return *published_ids holds the current ids.
visualization_msgs::MarkerArray objectsToMarkers(const std::vector<MapObject>& objects,
                                                 const std_msgs::Header& header,
                                                 std::set<int>* published_ids);

// x y z rgb (float32 each, rgb packed as in PCL); the points of each object (its LCCP segment, else
// its fused cloud) coloured by objectColor(id).
void objectsToPointCloud2(const std::vector<MapObject>& objects, const std_msgs::Header& header,
                          sensor_msgs::PointCloud2* cloud);
// The same for any selection of objects (one object: vision_msgs' source_cloud).
void objectsToPointCloud2(const std::vector<const MapObject*>& objects,
                          const std_msgs::Header& header, sensor_msgs::PointCloud2* cloud);

}  // namespace mvod
