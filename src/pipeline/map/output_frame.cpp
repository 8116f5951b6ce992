#include "multiview_object_detection/pipeline/map/output_frame.h"

#include <cmath>

namespace mvod {

Eigen::Isometry3d gravityAlignedPose(const GravityFrame& gravity, double floor_height_m) {
  Eigen::Isometry3d T_W_O = Eigen::Isometry3d::Identity();
  T_W_O.linear().col(0) = gravity.x_h;
  T_W_O.linear().col(1) = gravity.y_h;
  T_W_O.linear().col(2) = gravity.up;
  if (std::isfinite(floor_height_m)) T_W_O.translation() = floor_height_m * gravity.up;
  return T_W_O;
}

OrientedBox transformBox(const OrientedBox& box_W, const Eigen::Isometry3d& T_O_W) {
  OrientedBox box_O = box_W;
  box_O.center_m = T_O_W * box_W.center_m;
  box_O.rotation = T_O_W.linear() * box_W.rotation;
  return box_O;
}

std::vector<MapObject> objectsInFrame(const std::vector<MapObject>& objects_W,
                                      const Eigen::Isometry3d& T_O_W, bool with_clouds) {
  std::vector<MapObject> objects_O;
  objects_O.reserve(objects_W.size());
  for (const MapObject& object : objects_W) {
    MapObject copy;
    copy.id = object.id;
    copy.class_id = object.class_id;
    copy.class_name = object.class_name;
    copy.probability = object.probability;
    copy.observations = object.observations;
    copy.class_scores = object.class_scores;
    copy.box = transformBox(object.box, T_O_W);
    copy.yaw_rad = object.yaw_rad;
    copy.box_completed = object.box_completed;
    copy.observed_box = transformBox(object.observed_box, T_O_W);
    copy.first_keyframe = object.first_keyframe;
    copy.last_keyframe = object.last_keyframe;
    copy.first_seen_s = object.first_seen_s;
    copy.last_seen_s = object.last_seen_s;
    copy.existence = object.existence;
    if (with_clouds) {
      copy.points_W = transformCloud(object.points_W, T_O_W);
      copy.segment_W = transformCloud(object.segment_W, T_O_W);
      copy.view_boxes.reserve(object.view_boxes.size());
      for (const OrientedBox& view_box : object.view_boxes) {
        copy.view_boxes.push_back(transformBox(view_box, T_O_W));
      }
    } else {
      // Only the sizes, which the messages count (num_points: the segment, else the cloud).
      if (object.segment_W.empty()) {
        copy.points_W.resize(object.points_W.size());
      } else {
        copy.segment_W.resize(object.segment_W.size());
      }
    }
    objects_O.push_back(std::move(copy));
  }
  return objects_O;
}

}  // namespace mvod
