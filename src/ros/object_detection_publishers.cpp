#include "multiview_object_detection/ros/object_detection_publishers.h"

#include <visualization_msgs/MarkerArray.h>

#include <sstream>
#include <string>

#include "multiview_object_detection/detectors/segmenter_factory.h"
#include "multiview_object_detection/ros/conversions.h"
#include "multiview_object_detection/ros/markers.h"

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
  private_it_ = std::make_unique<image_transport::ImageTransport>(private_nh);
  detections_image_pub_ = private_it_->advertise("detections_image", 1);
}

void ObjectDetectionPublishers::publishRemoved(const std::vector<MapObject>& objects,
                                               const ros::Time& stamp) {
  if (objects.empty()) return;
  std_msgs::Header header;
  header.stamp = stamp;
  header.frame_id = config_.world_frame;
  removed_objects_pub_.publish(objectsToMsg(objects, header));
}

void ObjectDetectionPublishers::publishMap(const std::vector<MapObject>& objects,
                                           const ros::Time& stamp) {
  std_msgs::Header header;
  header.frame_id = config_.world_frame;
  header.stamp = stamp;
  {
    // One lock for objects and markers: the DELETEs must follow the published id set in order.
    std::lock_guard<std::mutex> lock(publish_mutex_);
    objects_pub_.publish(objectsToMsg(objects, header));
    markers_pub_.publish(objectsToMarkers(objects, header, &published_marker_ids_));
    if (config_.publish_object_cloud) {
      sensor_msgs::PointCloud2 cloud;
      objectsToPointCloud2(objects, header, &cloud);
      object_cloud_pub_.publish(cloud);
    }
  }
  stats_->update([&objects](ObjectDetectionStatistics& stats) {
    stats.objects = static_cast<int>(objects.size());
  });
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
