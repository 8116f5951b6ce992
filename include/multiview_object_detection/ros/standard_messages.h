// The map as the ROS ecosystem's 3D detection messages, for downstream code that does not know this
// package's Object: vision_msgs/Detection3DArray (task planners, semantic layers) and
// jsk_recognition_msgs/BoundingBoxArray (what jsk_rviz_plugins draws). Compiled only where CMake
// found the packages (MVOD_HAVE_VISION_MSGS, MVOD_HAVE_JSK_RECOGNITION_MSGS).
#pragma once

#include <std_msgs/Header.h>

#include <vector>

#include "multiview_object_detection/pipeline/map/object_database.h"

#ifdef MVOD_HAVE_VISION_MSGS
#include <vision_msgs/Detection3DArray.h>
#endif
#ifdef MVOD_HAVE_JSK_RECOGNITION_MSGS
#include <jsk_recognition_msgs/BoundingBoxArray.h>
#endif

namespace mvod {

#ifdef MVOD_HAVE_VISION_MSGS
// One Detection3D per object, in the objects' order: one hypothesis (id: the COCO class id, score:
// the probability, pose: the box's), the box, and with_clouds the object's points (x y z rgb, as
// ~object_cloud). header is each detection's and the array's.
vision_msgs::Detection3DArray objectsToDetection3DArray(const std::vector<MapObject>& objects,
                                                        const std_msgs::Header& header,
                                                        bool with_clouds);
#endif

#ifdef MVOD_HAVE_JSK_RECOGNITION_MSGS
// One BoundingBox per object, in the objects' order: label the COCO class id, value the
// probability.
jsk_recognition_msgs::BoundingBoxArray objectsToBoundingBoxArray(
    const std::vector<MapObject>& objects, const std_msgs::Header& header);
#endif

// Whether this build publishes them (for the start-up message and the tests).
bool publishesVisionMsgs();
bool publishesJskRecognitionMsgs();

}  // namespace mvod
