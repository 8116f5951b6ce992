// Where rviz draws the map's labels: each over its own box. rviz turns a TEXT_VIEW_FACING label to
// the viewer, so labels of boxes close together would cross from most views; such a label goes up
// a line, as little as it must, and a thin line joins it to its box. Pure geometry, like markers.h.
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
// objects[i]'s label, drawn text_heights_m[i] high. "Up" is the boxes' third axis (the floor
// normal, Eq. 4). A label reaches half its text's width around its box's centre. In id order, each
// label takes the lowest line over its own box's top that keeps a line's spacing from every earlier
// label it reaches; a newer object never moves an older label.
std::vector<LabelPlacement> placeLabels(const std::vector<const MapObject*>& objects,
                                        const std::vector<std::string>& texts,
                                        const std::vector<double>& text_heights_m);

}  // namespace mvod
