// What offline_detection --overlays draws on a keyframe's colour image, the picture a user checks
// first: the keyframe's detections (masks, boxes, class and score) with the map object each one was
// fused into or inserted as, and the map's boxes projected into the image with their ids.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "multiview_object_detection/pipeline/map/object_database.h"
#include "multiview_object_detection/pipeline/types/detection.h"
#include "multiview_object_detection/pipeline/types/rgbd_frame.h"

namespace mvod {

// object_ids: per detection, its map object (-1: not mapped), as KeyframeReport::object_ids. Boxes
// of `objects` (world frame) are drawn where the colour camera sees them (edges behind the camera
// are left out), each labelled "#id class".
cv::Mat drawKeyframeOverlay(const RgbdFrame& frame, const std::vector<Detection2D>& detections,
                            const std::vector<int>& object_ids,
                            const std::vector<MapObject>& objects);

}  // namespace mvod
