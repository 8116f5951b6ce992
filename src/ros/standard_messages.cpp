#include "multiview_object_detection/ros/standard_messages.h"

#include "multiview_object_detection/ros/conversions.h"
#include "multiview_object_detection/ros/markers.h"

namespace mvod {

#ifdef MVOD_HAVE_VISION_MSGS
vision_msgs::Detection3DArray objectsToDetection3DArray(const std::vector<MapObject>& objects,
                                                        const std_msgs::Header& header,
                                                        bool with_clouds) {
  vision_msgs::Detection3DArray array;
  array.header = header;
  array.detections.reserve(objects.size());
  for (const MapObject& object : objects) {
    vision_msgs::Detection3D detection;
    detection.header = header;
    detection.bbox.center = boxPoseToMsg(object.box);
    detection.bbox.size = boxSizeToMsg(object.box);
    vision_msgs::ObjectHypothesisWithPose hypothesis;
    hypothesis.id = object.class_id;
    hypothesis.score = object.probability;
    hypothesis.pose.pose = detection.bbox.center;
    detection.results.push_back(hypothesis);
    if (with_clouds) objectsToPointCloud2({&object}, header, &detection.source_cloud);
    array.detections.push_back(std::move(detection));
  }
  return array;
}
#endif

#ifdef MVOD_HAVE_JSK_RECOGNITION_MSGS
jsk_recognition_msgs::BoundingBoxArray objectsToBoundingBoxArray(
    const std::vector<MapObject>& objects, const std_msgs::Header& header) {
  jsk_recognition_msgs::BoundingBoxArray array;
  array.header = header;
  array.boxes.reserve(objects.size());
  for (const MapObject& object : objects) {
    jsk_recognition_msgs::BoundingBox box;
    box.header = header;
    box.pose = boxPoseToMsg(object.box);
    box.dimensions = boxSizeToMsg(object.box);
    box.value = static_cast<float>(object.probability);
    box.label = object.class_id < 0 ? 0u : static_cast<uint32_t>(object.class_id);
    array.boxes.push_back(std::move(box));
  }
  return array;
}
#endif

bool publishesVisionMsgs() {
#ifdef MVOD_HAVE_VISION_MSGS
  return true;
#else
  return false;
#endif
}

bool publishesJskRecognitionMsgs() {
#ifdef MVOD_HAVE_JSK_RECOGNITION_MSGS
  return true;
#else
  return false;
#endif
}

}  // namespace mvod
