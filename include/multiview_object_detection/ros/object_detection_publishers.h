// Everything the node publishes but /diagnostics (node_diagnostics.h): the map (objects, markers,
// object cloud), the keyframe path and the detection image. Topics are private (~objects, ...),
// latched where a late rviz should still see the map.
#pragma once

#include <image_transport/image_transport.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/map/object_database.h"
#include "multiview_object_detection/pipeline/types/detection.h"
#include "multiview_object_detection/ros/object_detection_ros_config.h"
#include "multiview_object_detection/ros/object_detection_statistics.h"

namespace mvod {

class ObjectDetectionPublishers {
 public:
  // Advertises every output (/diagnostics: NodeDiagnostics).
  ObjectDetectionPublishers(const ros::NodeHandle& nh, const ros::NodeHandle& nh_private,
                            const ObjectDetectionRosConfig& config, SharedStatistics* stats);

  ObjectDetectionPublishers(const ObjectDetectionPublishers&) = delete;
  ObjectDetectionPublishers& operator=(const ObjectDetectionPublishers&) = delete;

  // Objects, markers (DELETEs for the objects gone since the last call) and, if enabled, the
  // object cloud, all in the output frame, whose pose T_W_O in world_frame is sent as TF first
  // when it changed (output_frame.h). objects_W in world_frame. Safe from any thread.
  void publishMap(const std::vector<MapObject>& objects_W, const Eigen::Isometry3d& T_W_O,
                  const ros::Time& stamp);
  void publishKeyframePath(const nav_msgs::Path& path);
  // The objects the existence evidence or a pose correction removed, as they were last, each with
  // why (~removed_objects), so that a task planner learns of them; their markers go with the next
  // publishMap. reasons: one per object.
  void publishRemoved(const std::vector<MapObject>& objects_W,
                      const std::vector<std::string>& reasons, const Eigen::Isometry3d& T_W_O,
                      const ros::Time& stamp);
  // TF world_frame -> output_frame alone (publishMap sends it too).
  void publishOutputFrame(const Eigen::Isometry3d& T_W_O);
  // The objects as published: in the output frame (header.frame_id outputFrame()).
  std::vector<MapObject> inOutputFrame(const std::vector<MapObject>& objects_W,
                                       const Eigen::Isometry3d& T_W_O, bool with_clouds) const;
  const std::string& outputFrame() const { return config_.outputFrame(); }
  // Drawn only while someone subscribes.
  void publishDetectionImage(const cv::Mat& color_bgr, const std::vector<Detection2D>& detections,
                             const std_msgs::Header& header);

 private:
  // ~detections_3d and ~bounding_boxes, where built (standard_messages.h).
  void publishStandardMessages(const std::vector<MapObject>& objects,
                               const std_msgs::Header& header);
  // Sends TF world_frame -> output_frame when T_W_O moved (a new gravity or floor estimate).
  void sendOutputFrame(const Eigen::Isometry3d& T_W_O);

  ros::NodeHandle nh_;
  const ObjectDetectionRosConfig config_;  // fixed fields only (frames, publish_object_cloud)
  SharedStatistics* stats_;

  ros::Publisher objects_pub_;
  ros::Publisher removed_objects_pub_;
  ros::Publisher markers_pub_;
  ros::Publisher object_cloud_pub_;
  // Advertised only where the packages were found at build time (standard_messages.h).
  ros::Publisher detections_3d_pub_;   // vision_msgs/Detection3DArray
  ros::Publisher bounding_boxes_pub_;  // jsk_recognition_msgs/BoundingBoxArray
  ros::Publisher keyframes_pub_;
  std::unique_ptr<image_transport::ImageTransport> private_it_;
  image_transport::Publisher detections_image_pub_;
  std::mutex publish_mutex_;
  std::set<int> published_marker_ids_;  // publish_mutex_
  tf2_ros::StaticTransformBroadcaster output_frame_broadcaster_;
  std::optional<Eigen::Isometry3d> sent_T_W_O_;  // publish_mutex_
};

}  // namespace mvod
