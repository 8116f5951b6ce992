// The SLAM's corrected keyframe poses (`keyframe_poses`, nav_msgs/Path): after a loop closure or a
// global bundle adjustment, each PoseStamped is a keyframe's corrected colour-camera pose in the
// world frame, its header.stamp the stamp of that keyframe's images. Any subset of keyframes may
// come, at any time, repeatedly. Poses are checked here (finite, unit quaternion, a frame that TF
// can bring into world_frame) and handed on in one batch per message; the worker applies them
// between keyframes.
#pragma once

#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>

#include <atomic>
#include <functional>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/map/keyframe_history.h"
#include "multiview_object_detection/ros/object_detection_statistics.h"

namespace mvod {

class KeyframePosesInput {
 public:
  using CorrectionsCallback = std::function<void(std::vector<PoseCorrection>)>;

  KeyframePosesInput(const std::string& world_frame, const tf2_ros::Buffer& tf_buffer,
                     SharedStatistics* stats, const std::atomic<bool>& shut_down,
                     CorrectionsCallback on_corrections);
  void subscribe(ros::NodeHandle& nh);
  void unsubscribe() { sub_.shutdown(); }
  // The message's poses in world_frame; the refused ones are counted and named in *errors.
  std::vector<PoseCorrection> convert(const nav_msgs::Path& path,
                                      std::vector<std::string>* errors) const;

 private:
  void callback(const nav_msgs::PathConstPtr& msg);

  const std::string world_frame_;
  const tf2_ros::Buffer& tf_buffer_;
  SharedStatistics* stats_;
  const std::atomic<bool>& shut_down_;
  CorrectionsCallback on_corrections_;
  ros::Subscriber sub_;
};

}  // namespace mvod
