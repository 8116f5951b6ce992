// Between the RGB-D input and the worker: frames wait here for their camera pose (TF, or the pose
// topic buffered here) and, in keyframe_mode topic, for the keyframe stream; then the
// KeyframeSelector decides. The one place that knows about stamps and their order: out-of-order
// inputs are refused here, eviction of old frames and poses happens here, and ~reset clears it all
// here. Waiting never blocks a callback: frames are retried when a pose arrives and on a timer.
#pragma once

#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>

#include <atomic>
#include <deque>
#include <functional>
#include <mutex>
#include <string>

#include "multiview_object_detection/pipeline/stages/keyframe_selector.h"
#include "multiview_object_detection/ros/conversions.h"
#include "multiview_object_detection/ros/object_detection_publishers.h"
#include "multiview_object_detection/ros/object_detection_ros_config.h"
#include "multiview_object_detection/ros/object_detection_statistics.h"
#include "multiview_object_detection/ros/pending_frames.h"

namespace mvod {

class KeyframeBuffer {
 public:
  // Gets each selected keyframe, with input order kept (called with the buffer's lock held).
  using KeyframeCallback = std::function<void(KeyframeJob job)>;
  // Told when time jumped back (and on reset): what other buffers hold after `stamp` belongs to
  // the abandoned timeline (a zero stamp: everything).
  using TimeJumpCallback = std::function<void(const ros::Time& stamp)>;

  KeyframeBuffer(const ObjectDetectionRosConfig& config, const RgbdTopics& topics,
                 tf2_ros::Buffer& tf_buffer, ObjectDetectionPublishers* publishers,
                 SharedStatistics* stats, const std::atomic<bool>& shut_down,
                 KeyframeCallback on_keyframe);

  KeyframeBuffer(const KeyframeBuffer&) = delete;
  KeyframeBuffer& operator=(const KeyframeBuffer&) = delete;

  // Subscribes the pose topic (pose_source topic) and the keyframe topic (keyframe_mode topic) and
  // starts the retry timer.
  void start(ros::NodeHandle nh);
  void stop();

  void setTimeJumpCallback(TimeJumpCallback on_time_jump) {
    on_time_jump_ = std::move(on_time_jump);
  }

  // A checked input from RgbdInput (ROS callback thread). Refused when up to 1 s older than the
  // last one (out of order); more than 1 s older is a jump back in time (a restarted bag, or a
  // bogus future stamp before): the buffers are cleared and the frame is taken.
  void addFrame(PendingFrame frame);
  // Forgets the waiting frames, the buffered poses and detections, the TF buffer's transforms (the
  // static ones stay), the selector's state, the last stamp (a restarted bag may begin again) and
  // the keyframe path, and publishes the empty path.
  void reset();
  // Keyframe thresholds changed by dynamic reconfigure.
  void setKeyframeConfig(const KeyframeSelector::Config& keyframes);

 private:
  enum class Lookup { kReady, kWait, kFailed };

  void poseCallback(const geometry_msgs::PoseStampedConstPtr& msg);
  void keyframeCallback(const geometry_msgs::PoseStampedConstPtr& msg);
  void resolvePendingFrames();                                     // needs mutex_
  void handleTimeJumpBack(const ros::Time& stamp, double back_s);  // needs mutex_
  void dropPosesAfter(const ros::Time& stamp);                     // needs mutex_
  Lookup lookupCameraPose(const PendingFrame& frame, bool timed_out, Eigen::Isometry3d* T_W_C,
                          Eigen::Isometry3d* T_C_D, std::string* error);  // needs mutex_
  // The parts of lookupCameraPose: the depth camera in the colour camera (unregistered depth), and
  // the colour camera in the world from TF or from the pose topic (needs mutex_).
  Lookup lookupDepthToColor(const PendingFrame& frame, bool timed_out, Eigen::Isometry3d* T_C_D,
                            std::string* error) const;
  Lookup lookupTransform(const std::string& target, const std::string& source,
                         const ros::Time& stamp, bool timed_out, const std::string& what,
                         const std::string& waited, Eigen::Isometry3d* T, std::string* error) const;
  Lookup lookupPoseOnTopic(const PendingFrame& frame, bool timed_out, Eigen::Isometry3d* T_W_C,
                           std::string* error) const;

  const ObjectDetectionRosConfig config_;  // fixed fields only (frames, pose source, timeouts)
  const RgbdTopics topics_;
  tf2_ros::Buffer& tf_buffer_;  // cleared on reset
  ObjectDetectionPublishers* publishers_;
  SharedStatistics* stats_;
  const std::atomic<bool>& shut_down_;
  KeyframeCallback on_keyframe_;
  TimeJumpCallback on_time_jump_;

  ros::Subscriber pose_sub_;
  ros::Subscriber keyframe_sub_;
  ros::WallTimer pending_timer_;

  std::mutex mutex_;
  std::deque<PendingFrame> pending_;              // input order = stamp order
  std::deque<geometry_msgs::PoseStamped> poses_;  // pose_source topic, sorted by stamp
  ros::Time last_input_stamp_;
  KeyframeSelector selector_;
  int next_keyframe_index_ = 0;
  nav_msgs::Path keyframe_path_;
};

}  // namespace mvod
