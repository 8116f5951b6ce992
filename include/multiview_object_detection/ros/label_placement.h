// Where rviz draws the map's labels. rviz turns a TEXT_VIEW_FACING label to the viewer, so labels
// of boxes close together cross each other from most views. Labels whose texts could reach each
// other share one column, one line each, over the oldest object of the group; a thin line joins
// each label to its own box. Pure geometry, like markers.h.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/map/object_database.h"

namespace mvod {

struct LabelPlacement {
  Eigen::Vector3d position_m;  // the text's centre (rviz's pose of a TEXT_VIEW_FACING marker)
  Eigen::Vector3d box_top_m;   // the top of the object's box over its centre: the line's end
};

// One placement per object, in the order of `objects` (as many as texts, if fewer); texts[i] is
// objects[i]'s label, drawn text_height_m high. "Up" is the boxes' third axis (the floor normal,
// Eq. 4). A label reaches half its text's width around its column in every direction. In id order,
// a label joins the nearest column whose first label it reaches, else starts one over its own box;
// it takes the lowest line, above its column's boxes, that no earlier label it reaches holds. Newer
// objects go above older ones: an older label moves only when its column forms (it is lifted clear
// of the clouds around) or when a newer, taller box joins its column.
std::vector<LabelPlacement> placeLabels(const std::vector<const MapObject*>& objects,
                                        const std::vector<std::string>& texts,
                                        double text_height_m);

}  // namespace mvod
