#include "multiview_object_detection/ros/object_detection_publishers.h"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <ros/this_node.h>
#include <visualization_msgs/MarkerArray.h>

#include <sstream>
#include <string>

#include "multiview_object_detection/detectors/segmenter_factory.h"
#include "multiview_object_detection/ros/conversions.h"
#include "multiview_object_detection/ros/markers.h"

namespace mvod {
namespace {

diagnostic_msgs::KeyValue keyValue(const std::string& key, double value) {
  diagnostic_msgs::KeyValue kv;
  kv.key = key;
  std::ostringstream out;
  out << value;
  kv.value = out.str();
  return kv;
}

}  // namespace

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
  diagnostics_pub_ = nh_.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 10);
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

void ObjectDetectionPublishers::startDiagnostics() {
  diagnostics_timer_ = nh_.createWallTimer(ros::WallDuration(1.0),
                                           &ObjectDetectionPublishers::publishDiagnostics, this);
}

void ObjectDetectionPublishers::stopDiagnostics() { diagnostics_timer_.stop(); }

void ObjectDetectionPublishers::publishDiagnostics(const ros::WallTimerEvent& /*event*/) {
  const ObjectDetectionStatistics stats = stats_->get();
  diagnostic_msgs::DiagnosticStatus status;
  status.name = "object_detection: " + ros::this_node::getName();
  status.hardware_id = config_.world_frame;
  status.level = diagnostic_msgs::DiagnosticStatus::OK;
  status.message = "ok";
  if (stats.keyframes_dropped > dropped_at_last_diagnostics_) {
    status.level = diagnostic_msgs::DiagnosticStatus::WARN;
    status.message = "keyframes dropped: processing is slower than the keyframe rate";
  } else if (stats.autosave_failures > autosave_failures_at_last_diagnostics_) {
    status.level = diagnostic_msgs::DiagnosticStatus::WARN;
    status.message = "autosave failed (the previous autosave is kept; see the log)";
  } else if (stats.callback_exceptions > exceptions_at_last_diagnostics_) {
    status.level = diagnostic_msgs::DiagnosticStatus::WARN;
    status.message = "a callback failed with an exception (input dropped; see the log)";
  } else if (stats.stamps_refused > refused_at_last_diagnostics_) {
    status.level = diagnostic_msgs::DiagnosticStatus::WARN;
    status.message = "input refused for its stamp (past 2038 or far ahead of the clock)";
  } else if (stats.waiting_for_gravity) {
    status.level = diagnostic_msgs::DiagnosticStatus::WARN;
    status.message = "waiting for gravity";
  }
  dropped_at_last_diagnostics_ = stats.keyframes_dropped;
  exceptions_at_last_diagnostics_ = stats.callback_exceptions;
  refused_at_last_diagnostics_ = stats.stamps_refused;
  autosave_failures_at_last_diagnostics_ = stats.autosave_failures;
  status.values = {
      keyValue("frames received", stats.frames_received),
      keyValue("frames rejected", stats.frames_rejected),
      keyValue("stamps refused", stats.stamps_refused),
      keyValue("callback exceptions", stats.callback_exceptions),
      keyValue("autosaves", stats.autosaves),
      keyValue("autosave failures", stats.autosave_failures),
      keyValue("autosave ms", stats.autosave_ms),
      keyValue("autosave bytes", stats.autosave_bytes),
      keyValue("pose failures", stats.pose_failures),
      keyValue("time jumps back", stats.time_jumps),
      keyValue("detections capped", stats.detections_capped),
      keyValue("keyframes selected", stats.keyframes_selected),
      keyValue("keyframes dropped", stats.keyframes_dropped),
      keyValue("keyframes cancelled", stats.keyframes_cancelled),
      keyValue("keyframes processed", stats.keyframes_processed),
      keyValue("keyframes failed", stats.keyframes_failed),
      keyValue("queue length", stats.queue_length),
      keyValue("objects", stats.objects),
      keyValue("removed atypical", stats.removed_atypical),
      keyValue("removed intersecting", stats.removed_intersecting),
      keyValue("detection ms", stats.detection_ms),
      keyValue("extraction ms", stats.stage_times.extraction_ms),
      keyValue("filter ms", stats.stage_times.filter_ms),
      keyValue("lccp ms", stats.stage_times.lccp_ms),
      keyValue("manhattan ms", stats.stage_times.manhattan_ms),
      keyValue("fusion ms", stats.stage_times.fusion_ms),
      keyValue("existence ms", stats.stage_times.existence_ms),
      keyValue("refinement ms", stats.stage_times.refinement_ms),
      keyValue("keyframe total ms", stats.stage_times.total_ms),
      keyValue("latency ms", stats.latency_ms),
      keyValue("latency median ms", stats.latency_median_ms),
      keyValue("removed gone", stats.removed_gone),
      keyValue("keyframe pose messages", stats.keyframe_pose_messages),
      keyValue("keyframe poses refused", stats.keyframe_poses_refused),
      keyValue("keyframe poses unmatched", stats.keyframe_poses_unmatched),
      keyValue("corrections applied", stats.corrections_applied),
      keyValue("keyframes corrected", stats.keyframes_corrected),
      keyValue("correction ms", stats.correction_ms),
  };
  diagnostic_msgs::DiagnosticArray array;
  array.header.stamp = ros::Time::now();
  array.status.push_back(status);
  diagnostics_pub_.publish(array);
}

}  // namespace mvod
