// The RGB-D input, as depth_image_proc takes it: colour image, depth image and camera_info (and,
// for unregistered depth, the depth camera_info) synchronised by message_filters, checked on their
// headers before anything is copied, and handed on as a PendingFrame. Never blocks.
#pragma once

#include <image_transport/image_transport.h>
#include <image_transport/subscriber_filter.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/sync_policies/exact_time.h>
#include <message_filters/synchronizer.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <atomic>
#include <functional>
#include <memory>

#include "multiview_object_detection/ros/conversions.h"
#include "multiview_object_detection/ros/frame_gaps.h"
#include "multiview_object_detection/ros/object_detection_ros_config.h"
#include "multiview_object_detection/ros/object_detection_statistics.h"
#include "multiview_object_detection/ros/pending_frames.h"
#include "multiview_object_detection/ros/stamp_filter.h"

namespace mvod {

class RgbdInput {
 public:
  using FrameCallback = std::function<void(PendingFrame frame)>;

  // Resolves the input topics (as remapped); subscribes nothing yet. `shut_down` set: inputs are
  // ignored.
  RgbdInput(const ros::NodeHandle& nh, const ros::NodeHandle& nh_private,
            const ObjectDetectionRosConfig& config, SharedStatistics* stats,
            const std::atomic<bool>& shut_down);

  RgbdInput(const RgbdInput&) = delete;
  RgbdInput& operator=(const RgbdInput&) = delete;

  // The resolved topic names: every message about an input names it by these.
  const RgbdTopics& topics() const { return topics_; }

  // Subscribes; each synchronised input that passes the checks goes to `callback` (on the ROS
  // callback thread).
  void subscribe(FrameCallback callback);
  void unsubscribe();

 private:
  using Image = sensor_msgs::Image;
  using CameraInfo = sensor_msgs::CameraInfo;
  using ApproxPolicy3 = message_filters::sync_policies::ApproximateTime<Image, Image, CameraInfo>;
  using ExactPolicy3 = message_filters::sync_policies::ExactTime<Image, Image, CameraInfo>;
  using ApproxPolicy4 =
      message_filters::sync_policies::ApproximateTime<Image, Image, CameraInfo, CameraInfo>;
  using ExactPolicy4 =
      message_filters::sync_policies::ExactTime<Image, Image, CameraInfo, CameraInfo>;

  // The synchroniser, new and empty, on the stamp filters.
  void makeSynchronizer();
  // A stamp went back on one input: the synchroniser starts afresh (a throttled warning).
  void restartSynchronizer(const std::string& topic, const ros::Time& last, const ros::Time& now);

  void rgbdCallback(const sensor_msgs::ImageConstPtr& color,
                    const sensor_msgs::ImageConstPtr& depth,
                    const sensor_msgs::CameraInfoConstPtr& color_info,
                    const sensor_msgs::CameraInfoConstPtr& depth_info);

  ros::NodeHandle nh_;
  ros::NodeHandle nh_private_;
  const ObjectDetectionRosConfig config_;  // fixed fields only (camera_frame, pose_source, sync)
  SharedStatistics* stats_;
  const std::atomic<bool>& shut_down_;
  RgbdTopics topics_;
  FrameCallback callback_;
  FrameGaps gaps_;  // frames lost before the callback (synchronised callbacks: one at a time)

  std::unique_ptr<image_transport::ImageTransport> it_;
  image_transport::SubscriberFilter color_sub_;
  image_transport::SubscriberFilter depth_sub_;
  message_filters::Subscriber<CameraInfo> color_info_sub_;
  message_filters::Subscriber<CameraInfo> depth_info_sub_;
  // Between the subscribers and the synchroniser: stamps it cannot hold are refused.
  std::unique_ptr<StampFilter<Image>> color_stamps_;
  std::unique_ptr<StampFilter<Image>> depth_stamps_;
  std::unique_ptr<StampFilter<CameraInfo>> color_info_stamps_;
  std::unique_ptr<StampFilter<CameraInfo>> depth_info_stamps_;
  std::unique_ptr<message_filters::Synchronizer<ApproxPolicy3>> approx_sync3_;
  std::unique_ptr<message_filters::Synchronizer<ExactPolicy3>> exact_sync3_;
  std::unique_ptr<message_filters::Synchronizer<ApproxPolicy4>> approx_sync4_;
  std::unique_ptr<message_filters::Synchronizer<ExactPolicy4>> exact_sync4_;
};

}  // namespace mvod
