// The node's TF listener: /tf and /tf_static into the tf2 buffer, as tf2_ros::TransformListener
// does (own callback queue and thread, so transforms arrive while other callbacks run), but a
// transform stamped where tf2's time arithmetic overflows is refused (checkInputStamp), and an
// exception inside tf2 costs that message only, not the process. With a TfStampCheck it also
// watches how the SLAM stamps its TF (stats.tf_stamp_problem, a warning when it goes wrong).
#pragma once

#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>

#include <memory>

#include "multiview_object_detection/ros/object_detection_statistics.h"
#include "multiview_object_detection/ros/tf_stamp_check.h"

namespace mvod {

class TfInput {
 public:
  // stamp_check: may be null (no check); it must outlive this.
  TfInput(tf2_ros::Buffer* buffer, SharedStatistics* stats, TfStampCheck* stamp_check = nullptr);
  ~TfInput();
  TfInput(const TfInput&) = delete;
  TfInput& operator=(const TfInput&) = delete;

  // Subscribes /tf and /tf_static (as remapped) and starts the thread.
  void start(const ros::NodeHandle& nh);

 private:
  void callback(const ros::MessageEvent<const tf2_msgs::TFMessage>& event, bool is_static);
  // Once a second (wall time): the check's verdict into the statistics, logged when it changes.
  void judgeStamps();

  tf2_ros::Buffer* buffer_;
  SharedStatistics* stats_;
  TfStampCheck* stamp_check_;
  ros::WallTime last_judged_;
  std::string stamp_problem_;
  ros::CallbackQueue queue_;
  std::unique_ptr<ros::AsyncSpinner> spinner_;
  ros::Subscriber tf_sub_;
  ros::Subscriber tf_static_sub_;
};

}  // namespace mvod
