// What offline_detection --overlays draws on a keyframe's colour image, the picture a user checks
// first: the keyframe's detections (masks, boxes, class and score), each with where it went (the
// map object it was fused into or inserted as, or why it was not mapped), over the map's boxes
// projected into the image, lighter, with their ids where the labels fit.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/map/object_database.h"
#include "multiview_object_detection/pipeline/types/detection.h"
#include "multiview_object_detection/pipeline/types/rgbd_frame.h"

namespace mvod {

// object_ids: per detection, its map object (-1: not mapped), as KeyframeReport::object_ids;
// drop_reasons: per detection, why it was not mapped (plain words; may be shorter or empty). Boxes
// of `objects` (world frame) are drawn where the colour camera sees them (edges behind the camera
// are left out), each labelled "#id class" where the label fits beside it.
cv::Mat drawKeyframeOverlay(const RgbdFrame& frame, const std::vector<Detection2D>& detections,
                            const std::vector<int>& object_ids,
                            const std::vector<std::string>& drop_reasons,
                            const std::vector<MapObject>& objects);

}  // namespace mvod
