#include "multiview_object_detection/ros/object_detection_publishers.h"

#include <visualization_msgs/MarkerArray.h>

#include <sstream>
#include <string>

#include "multiview_object_detection/detectors/segmenter_factory.h"
#include "multiview_object_detection/pipeline/map/output_frame.h"
#include "multiview_object_detection/ros/conversions.h"
#include "multiview_object_detection/ros/markers.h"
#include "multiview_object_detection/ros/standard_messages.h"

namespace mvod {

ObjectDetectionPublishers::ObjectDetectionPublishers(const ros::NodeHandle& nh,
                                                     const ros::NodeHandle& nh_private,
                                                     const ObjectDetectionRosConfig& config,
                                                     SharedStatistics* stats)
    : nh_(nh), config_(config), stats_(stats) {
  ros::NodeHandle private_nh(nh_private);
  objects_pub_ = private_nh.advertise<multiview_object_detection::ObjectArray>("objects", 1, true);
  removed_objects_pub_ =
      private_nh.advertise<multiview_object_detection::ObjectArray>("removed_objects", 10);
  markers_pub_ = private_nh.advertise<visualization_msgs::MarkerArray>("markers", 1, true);
  object_cloud_pub_ = private_nh.advertise<sensor_msgs::PointCloud2>("object_cloud", 1, true);
  keyframes_pub_ = private_nh.advertise<nav_msgs::Path>("keyframes", 1, true);
#ifdef MVOD_HAVE_VISION_MSGS
  detections_3d_pub_ =
      private_nh.advertise<vision_msgs::Detection3DArray>("detections_3d", 1, true);
#endif
#ifdef MVOD_HAVE_JSK_RECOGNITION_MSGS
  bounding_boxes_pub_ =
      private_nh.advertise<jsk_recognition_msgs::BoundingBoxArray>("bounding_boxes", 1, true);
#endif
  private_it_ = std::make_unique<image_transport::ImageTransport>(private_nh);
  detections_image_pub_ = private_it_->advertise("detections_image", 1);
}

std::vector<MapObject> ObjectDetectionPublishers::inOutputFrame(
    const std::vector<MapObject>& objects_W, const Eigen::Isometry3d& T_W_O,
    bool with_clouds) const {
  if (!config_.publishesOutputFrame()) return objects_W;
  return objectsInFrame(objects_W, T_W_O.inverse(), with_clouds);
}

void ObjectDetectionPublishers::publishOutputFrame(const Eigen::Isometry3d& T_W_O) {
  std::lock_guard<std::mutex> lock(publish_mutex_);
  sendOutputFrame(T_W_O);
}

void ObjectDetectionPublishers::sendOutputFrame(const Eigen::Isometry3d& T_W_O) {
  if (!config_.publishesOutputFrame()) return;
  if (sent_T_W_O_ && sent_T_W_O_->isApprox(T_W_O, 1e-9)) return;
  geometry_msgs::TransformStamped transform;
  transform.transform = transformToMsg(T_W_O);
  transform.header.stamp = ros::Time::now();
  transform.header.frame_id = config_.world_frame;
  transform.child_frame_id = config_.output_frame;
  output_frame_broadcaster_.sendTransform(transform);
  sent_T_W_O_ = T_W_O;
}

void ObjectDetectionPublishers::publishRemoved(const std::vector<MapObject>& objects_W,
                                               const std::vector<std::string>& reasons,
                                               const Eigen::Isometry3d& T_W_O,
                                               const ros::Time& stamp) {
  if (objects_W.empty()) return;
  std_msgs::Header header;
  header.stamp = stamp;
  header.frame_id = outputFrame();
  multiview_object_detection::ObjectArray msg =
      objectsToMsg(inOutputFrame(objects_W, T_W_O, false), header);
  for (std::size_t i = 0; i < msg.objects.size() && i < reasons.size(); ++i) {
    msg.objects[i].removed_reason = reasons[i];
  }
  removed_objects_pub_.publish(msg);
}

void ObjectDetectionPublishers::publishMap(const std::vector<MapObject>& objects_W,
                                           const Eigen::Isometry3d& T_W_O, const ros::Time& stamp) {
  std_msgs::Header header;
  header.frame_id = outputFrame();
  header.stamp = stamp;
  // A copy only when the frames differ (objects_W holds the evidence grids: not copied for
  // nothing).
  std::vector<MapObject> objects_O;
  if (config_.publishesOutputFrame()) {
    objects_O = objectsInFrame(objects_W, T_W_O.inverse(), config_.publish_object_cloud);
  }
  const std::vector<MapObject>& objects = config_.publishesOutputFrame() ? objects_O : objects_W;
  {
    // One lock for objects and markers: the DELETEs must follow the published id set in order.
    std::lock_guard<std::mutex> lock(publish_mutex_);
    sendOutputFrame(T_W_O);
    objects_pub_.publish(objectsToMsg(objects, header));
    markers_pub_.publish(objectsToMarkers(objects, header, &published_marker_ids_));
    if (config_.publish_object_cloud) {
      sensor_msgs::PointCloud2 cloud;
      objectsToPointCloud2(objects, header, &cloud);
      object_cloud_pub_.publish(cloud);
    }
    publishStandardMessages(objects, header);
  }
  stats_->update([&objects](ObjectDetectionStatistics& stats) {
    stats.objects = static_cast<int>(objects.size());
  });
}

void ObjectDetectionPublishers::publishStandardMessages(const std::vector<MapObject>& objects,
                                                        const std_msgs::Header& header) {
#ifdef MVOD_HAVE_VISION_MSGS
  detections_3d_pub_.publish(
      objectsToDetection3DArray(objects, header, config_.publish_object_cloud));
#endif
#ifdef MVOD_HAVE_JSK_RECOGNITION_MSGS
  bounding_boxes_pub_.publish(objectsToBoundingBoxArray(objects, header));
#endif
}

void ObjectDetectionPublishers::publishKeyframePath(const nav_msgs::Path& path) {
  keyframes_pub_.publish(path);
}

void ObjectDetectionPublishers::publishDetectionImage(const cv::Mat& color_bgr,
                                                      const std::vector<Detection2D>& detections,
                                                      const std_msgs::Header& header) {
  if (detections_image_pub_.getNumSubscribers() > 0) {
    detections_image_pub_.publish(colorImageToMsg(drawDetections(color_bgr, detections), header));
  }
}

}  // namespace mvod
