#include "multiview_object_detection/ros/keyframe_poses_input.h"

#include <tf2/exceptions.h>

#include <map>
#include <utility>

#include "multiview_object_detection/ros/conversions.h"
#include "multiview_object_detection/ros/input_guard.h"
#include "multiview_object_detection/ros/throttled_log.h"

namespace mvod {

KeyframePosesInput::KeyframePosesInput(const std::string& world_frame,
                                       const tf2_ros::Buffer& tf_buffer, SharedStatistics* stats,
                                       const std::atomic<bool>& shut_down,
                                       CorrectionsCallback on_corrections)
    : world_frame_(world_frame),
      tf_buffer_(tf_buffer),
      stats_(stats),
      shut_down_(shut_down),
      on_corrections_(std::move(on_corrections)) {}

void KeyframePosesInput::subscribe(ros::NodeHandle& nh) {
  sub_ = nh.subscribe<nav_msgs::Path>(
      "keyframe_poses", 2,
      guardedCallback<nav_msgs::Path>(
          nh.resolveName("keyframe_poses"), stats_,
          [this](const nav_msgs::PathConstPtr& msg) { callback(msg); }));
}

std::vector<PoseCorrection> KeyframePosesInput::convert(const nav_msgs::Path& path,
                                                        std::vector<std::string>* errors) const {
  std::vector<PoseCorrection> corrections;
  corrections.reserve(path.poses.size());
  // One TF look-up per frame named in the message (the latest transform: a fixed frame of the
  // SLAM's map, e.g. ORB-SLAM2's map frame under the robot's odometry frame).
  std::map<std::string, std::pair<bool, Eigen::Isometry3d>> frames;
  const auto fail = [errors](const std::string& text) {
    if (errors != nullptr) errors->push_back(text);
  };
  for (std::size_t i = 0; i < path.poses.size(); ++i) {
    const geometry_msgs::PoseStamped& pose = path.poses[i];
    const std::string frame =
        pose.header.frame_id.empty() ? path.header.frame_id : pose.header.frame_id;
    const std::string what =
        "pose " + std::to_string(i) + " (stamp " + std::to_string(pose.header.stamp.toSec()) + ")";
    const Status stamp = checkInputStamp(pose.header.stamp, ros::Time::now(), what);
    if (!stamp) {
      fail(stamp.message());
      continue;
    }
    Eigen::Isometry3d T_F_C;
    const Status valid = poseFromMsg(pose.pose, &T_F_C);
    if (!valid) {
      fail(what + ": " + valid.message());
      continue;
    }
    Eigen::Isometry3d T_W_F = Eigen::Isometry3d::Identity();
    if (!frame.empty() && frame != world_frame_) {
      auto known = frames.find(frame);
      if (known == frames.end()) {
        std::pair<bool, Eigen::Isometry3d> entry(false, Eigen::Isometry3d::Identity());
        try {
          const geometry_msgs::TransformStamped tf =
              tf_buffer_.lookupTransform(world_frame_, frame, ros::Time(0));
          entry.first = transformFromMsg(tf.transform, &entry.second).ok();
        } catch (const tf2::TransformException&) {
          entry.first = false;
        }
        known = frames.emplace(frame, entry).first;
      }
      if (!known->second.first) {
        fail(what + ": in frame '" + frame + "', and there is no valid TF '" + world_frame_ +
             "' <- '" + frame + "'");
        continue;
      }
      T_W_F = known->second.second;
    }
    PoseCorrection correction;
    correction.stamp_s = pose.header.stamp.toSec();
    correction.T_W_C = T_W_F * T_F_C;
    corrections.push_back(correction);
  }
  return corrections;
}

void KeyframePosesInput::callback(const nav_msgs::PathConstPtr& msg) {
  if (shut_down_) return;
  std::vector<std::string> errors;
  std::vector<PoseCorrection> corrections = convert(*msg, &errors);
  const std::string topic = sub_.getTopic();
  if (!errors.empty()) {
    errorThrottled("keyframe poses on " + topic + ": " + std::to_string(errors.size()) + " of " +
                   std::to_string(msg->poses.size()) + " refused, e.g. " + errors.front());
  }
  stats_->update([&](ObjectDetectionStatistics& s) {
    ++s.keyframe_pose_messages;
    s.keyframe_poses_refused += static_cast<int>(errors.size());
  });
  if (!corrections.empty()) on_corrections_(std::move(corrections));
}

}  // namespace mvod
