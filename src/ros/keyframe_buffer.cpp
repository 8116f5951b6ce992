#include "multiview_object_detection/ros/keyframe_buffer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <utility>

#include "multiview_object_detection/ros/input_guard.h"
#include "multiview_object_detection/ros/throttled_log.h"

namespace mvod {
namespace {

using Clock = std::chrono::steady_clock;

constexpr size_t kMaxPendingFrames = 100;
constexpr size_t kMaxBufferedPoses = 2000;
constexpr size_t kMaxPathPoses = 100000;

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

}  // namespace

KeyframeBuffer::KeyframeBuffer(const ObjectDetectionRosConfig& config, const RgbdTopics& topics,
                               tf2_ros::Buffer& tf_buffer, ObjectDetectionPublishers* publishers,
                               SharedStatistics* stats, const std::atomic<bool>& shut_down,
                               KeyframeCallback on_keyframe)
    : config_(config),
      topics_(topics),
      tf_buffer_(tf_buffer),
      publishers_(publishers),
      stats_(stats),
      shut_down_(shut_down),
      on_keyframe_(std::move(on_keyframe)),
      selector_(config.keyframes) {
  keyframe_path_.header.frame_id = config_.world_frame;
}

void KeyframeBuffer::start(ros::NodeHandle nh) {
  if (config_.pose_source == "topic") {
    stats_->inputs().expect(nh.resolveName("pose"), true);
    pose_sub_ = nh.subscribe<geometry_msgs::PoseStamped>(
        "pose", 100,
        guardedCallback<geometry_msgs::PoseStamped>(
            nh.resolveName("pose"), stats_,
            [this](const geometry_msgs::PoseStampedConstPtr& msg) { poseCallback(msg); }));
  }
  if (config_.keyframes.mode == KeyframeSelector::Mode::kExternal) {
    keyframe_sub_ = nh.subscribe<geometry_msgs::PoseStamped>(
        "keyframe", 100,
        guardedCallback<geometry_msgs::PoseStamped>(
            nh.resolveName("keyframe"), stats_,
            [this](const geometry_msgs::PoseStampedConstPtr& msg) { keyframeCallback(msg); }));
  }
  // Frames waiting for a pose are retried when a pose arrives and on this timer (TF, timeouts).
  pending_timer_ = nh.createWallTimer(ros::WallDuration(0.02), [this](const ros::WallTimerEvent&) {
    runGuarded("the pose wait timer", stats_, [this] {
      std::lock_guard<std::mutex> lock(mutex_);
      resolvePendingFrames();
    });
  });
}

void KeyframeBuffer::stop() {
  pending_timer_.stop();
  pose_sub_.shutdown();
  keyframe_sub_.shutdown();
}

void KeyframeBuffer::addFrame(PendingFrame frame) {
  std::lock_guard<std::mutex> lock(mutex_);
  const std_msgs::Header& header = frame.msgs.color->header;
  if (!last_input_stamp_.isZero() && header.stamp <= last_input_stamp_) {
    const double back_s = (last_input_stamp_ - header.stamp).toSec();
    if (back_s <= kTimeJumpBackS) {
      const std::string text = "RGB-D input dropped: " + describeInput(topics_.color, header) +
                               " is older than or as old as the last frame (stamp " +
                               stampText(last_input_stamp_) + "): out-of-order or repeated stamp";
      errorThrottled(text);
      stats_->update([&text](ObjectDetectionStatistics& stats) {
        ++stats.frames_rejected;
        stats.last_frame_rejection = text;
      });
      return;
    }
    handleTimeJumpBack(header.stamp, back_s);
  }
  last_input_stamp_ = header.stamp;
  pending_.push_back(std::move(frame));
  while (pending_.size() > kMaxPendingFrames) {
    const PendingFrame& oldest = pending_.front();
    const std::string text = "frame " + describeInput(topics_.color, oldest.msgs.color->header) +
                             " dropped: too many frames waiting for their camera pose";
    errorThrottled(text);
    pending_.pop_front();
    stats_->update([&text](ObjectDetectionStatistics& stats) {
      ++stats.pose_failures;
      stats.last_pose_failure = text;
    });
  }
  resolvePendingFrames();
}

void KeyframeBuffer::handleTimeJumpBack(const ros::Time& stamp, double back_s) {
  const size_t dropped_frames = pending_.size();
  pending_.clear();
  dropPosesAfter(stamp + ros::Duration(kTimeJumpBackS));
  selector_.reset();
  if (on_time_jump_) on_time_jump_(stamp + ros::Duration(kTimeJumpBackS));
  stats_->update([](ObjectDetectionStatistics& stats) { ++stats.time_jumps; });
  char seconds[32];
  std::snprintf(seconds, sizeof(seconds), "%.3f", back_s);
  ROS_WARN(
      "detected jump back in time of %s s on '%s' (stamp %s after %s; a restarted bag?): "
      "%zu waiting frames, later poses and detections dropped, keyframe selection restarted; "
      "the map is kept (call ~reset to clear it)",
      seconds, topics_.color.c_str(), stampText(stamp).c_str(),
      stampText(last_input_stamp_).c_str(), dropped_frames);
}

void KeyframeBuffer::dropPosesAfter(const ros::Time& stamp) {
  while (!poses_.empty() && poses_.back().header.stamp > stamp) poses_.pop_back();
}

void KeyframeBuffer::reset() {
  std::lock_guard<std::mutex> lock(mutex_);
  pending_.clear();
  poses_.clear();
  // A bag replayed after ~reset sends the same stamps again: tf2 would keep the old transforms
  // and warn TF_REPEATED_DATA for each new one. Static transforms are kept (tf2 keeps them).
  tf_buffer_.clear();
  if (on_time_jump_) on_time_jump_(ros::Time());  // all detections
  selector_.reset();
  last_input_stamp_ = ros::Time();  // a restarted bag may begin again
  keyframe_path_.poses.clear();
  keyframe_path_.header.stamp = ros::Time::now();
  publishers_->publishKeyframePath(keyframe_path_);
}

void KeyframeBuffer::setKeyframeConfig(const KeyframeSelector::Config& keyframes) {
  std::lock_guard<std::mutex> lock(mutex_);
  selector_.setConfig(keyframes);
}

void KeyframeBuffer::poseCallback(const geometry_msgs::PoseStampedConstPtr& msg) {
  Eigen::Isometry3d T_W_C;
  const Status valid = poseFromMsg(msg->pose, &T_W_C);
  if (!valid) {
    errorThrottled("camera pose " + describeInput(pose_sub_.getTopic(), msg->header) +
                   " ignored: " + valid.message());
    return;
  }
  if (!msg->header.frame_id.empty() && msg->header.frame_id != config_.world_frame) {
    warnThrottled("camera pose " + describeInput(pose_sub_.getTopic(), msg->header) +
                  " is in frame '" + msg->header.frame_id + "', not world_frame '" +
                  config_.world_frame + "': used as if it were world_frame");
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (!poses_.empty() &&
      (poses_.back().header.stamp - msg->header.stamp).toSec() > kTimeJumpBackS) {
    warnThrottled("camera pose " + describeInput(pose_sub_.getTopic(), msg->header) +
                  ": time jumped back from " + stampText(poses_.back().header.stamp) +
                  ": the buffered poses after it are dropped");
    dropPosesAfter(msg->header.stamp + ros::Duration(kTimeJumpBackS));
  }
  const auto it =
      std::upper_bound(poses_.begin(), poses_.end(), msg->header.stamp,
                       [](const ros::Time& stamp, const geometry_msgs::PoseStamped& pose) {
                         return stamp < pose.header.stamp;
                       });
  poses_.insert(it, *msg);
  while (poses_.size() > kMaxBufferedPoses) poses_.pop_front();
  resolvePendingFrames();
}

void KeyframeBuffer::keyframeCallback(const geometry_msgs::PoseStampedConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  selector_.addExternalKeyframe(msg->header.stamp.toSec());
  resolvePendingFrames();
}

KeyframeBuffer::Lookup KeyframeBuffer::lookupCameraPose(const PendingFrame& frame, bool timed_out,
                                                        Eigen::Isometry3d* T_W_C,
                                                        Eigen::Isometry3d* T_C_D,
                                                        std::string* error) {
  const Lookup depth = lookupDepthToColor(frame, timed_out, T_C_D, error);
  if (depth != Lookup::kReady) return depth;
  if (config_.pose_source == "tf") {
    const std_msgs::Header& header = frame.msgs.color->header;
    return lookupTransform(
        config_.world_frame, frame.camera_frame, header.stamp, timed_out,
        describeInput(topics_.color, header),
        "at the image stamp within tf_timeout_s (" + std::to_string(config_.tf_timeout_s) + " s)",
        T_W_C, error);
  }
  return lookupPoseOnTopic(frame, timed_out, T_W_C, error);
}

KeyframeBuffer::Lookup KeyframeBuffer::lookupDepthToColor(const PendingFrame& frame, bool timed_out,
                                                          Eigen::Isometry3d* T_C_D,
                                                          std::string* error) const {
  // Unregistered depth: depth camera -> colour camera, a static transform.
  *T_C_D = Eigen::Isometry3d::Identity();
  if (!frame.msgs.depth_info) return Lookup::kReady;
  const std::string& depth_frame = frame.msgs.depth_info->header.frame_id.empty()
                                       ? frame.msgs.depth->header.frame_id
                                       : frame.msgs.depth_info->header.frame_id;
  if (depth_frame.empty() || depth_frame == frame.camera_frame) return Lookup::kReady;
  return lookupTransform(
      frame.camera_frame, depth_frame, ros::Time(0), timed_out,
      describeInput(topics_.color, frame.msgs.color->header),
      "(depth to colour camera) after " + std::to_string(config_.tf_timeout_s) + " s", T_C_D,
      error);
}

KeyframeBuffer::Lookup KeyframeBuffer::lookupTransform(
    const std::string& target, const std::string& source, const ros::Time& stamp, bool timed_out,
    const std::string& what, const std::string& waited, Eigen::Isometry3d* T,
    std::string* error) const {
  std::string tf_error;
  if (!tf_buffer_.canTransform(target, source, stamp, &tf_error)) {
    if (!timed_out) return Lookup::kWait;
    *error = "frame " + what + ": no TF '" + target + "' <- '" + source + "' " + waited + ": " +
             tf_error;
    return Lookup::kFailed;
  }
  try {
    const geometry_msgs::TransformStamped tf = tf_buffer_.lookupTransform(target, source, stamp);
    const Status valid = transformFromMsg(tf.transform, T);
    if (!valid) {
      *error = "frame " + what + ": TF '" + target + "' <- '" + source +
               "' is invalid: " + valid.message();
      return Lookup::kFailed;
    }
  } catch (const tf2::TransformException& e) {
    *error = "frame " + what + ": TF lookup failed: " + e.what();
    return Lookup::kFailed;
  }
  return Lookup::kReady;
}

KeyframeBuffer::Lookup KeyframeBuffer::lookupPoseOnTopic(const PendingFrame& frame, bool timed_out,
                                                         Eigen::Isometry3d* T_W_C,
                                                         std::string* error) const {
  const std_msgs::Header& header = frame.msgs.color->header;
  const ros::Time stamp = header.stamp;
  const double max_diff_s = config_.pose_max_time_diff_s;
  // The nearest pose in time. Once a pose at or after the image stamp has arrived, later poses can
  // only be further away.
  const geometry_msgs::PoseStamped* best = nullptr;
  double best_dt = std::numeric_limits<double>::infinity();
  for (const geometry_msgs::PoseStamped& pose : poses_) {
    const double dt = std::abs((pose.header.stamp - stamp).toSec());
    if (dt < best_dt) {
      best_dt = dt;
      best = &pose;
    }
  }
  const bool final_answer = timed_out || (!poses_.empty() && poses_.back().header.stamp >= stamp);
  if (!final_answer) return Lookup::kWait;
  const std::string what = describeInput(topics_.color, header);
  if (best == nullptr || best_dt > max_diff_s) {
    std::ostringstream text;
    text << "frame " << what << ": no camera pose on '" << pose_sub_.getTopic()
         << "' within pose_max_time_diff_s (" << max_diff_s << " s) of the image stamp";
    if (best != nullptr) {
      text << " (nearest " << best_dt << " s away)";
    } else {
      text << " (none received yet)";
    }
    *error = text.str();
    return Lookup::kFailed;
  }
  const Status valid = poseFromMsg(best->pose, T_W_C);
  if (!valid) {
    *error = "frame " + what + ": camera pose is invalid: " + valid.message();
    return Lookup::kFailed;
  }
  return Lookup::kReady;
}

void KeyframeBuffer::resolvePendingFrames() {
  if (shut_down_) return;
  while (!pending_.empty()) {
    const PendingFrame& frame = pending_.front();
    const bool timed_out = secondsSince(frame.received) >= config_.tf_timeout_s;
    Eigen::Isometry3d T_W_C = Eigen::Isometry3d::Identity();
    Eigen::Isometry3d T_C_D = Eigen::Isometry3d::Identity();
    std::string error;
    const Lookup lookup = lookupCameraPose(frame, timed_out, &T_W_C, &T_C_D, &error);
    if (lookup == Lookup::kWait) break;
    if (lookup == Lookup::kFailed) {
      errorThrottled(error);
      pending_.pop_front();
      stats_->update([&error](ObjectDetectionStatistics& stats) {
        ++stats.pose_failures;
        stats.last_pose_failure = error;
      });
      continue;
    }
    const ros::Time stamp = frame.msgs.color->header.stamp;
    // keyframe_mode topic: wait (up to tf_timeout_s) until the keyframe stream has passed this
    // stamp.
    if (!selector_.canDecide(stamp.toSec()) && !timed_out) break;
    if (selector_.isKeyframe(T_W_C, stamp.toSec())) {
      KeyframeJob job;
      job.msgs = frame.msgs;
      job.camera_frame = frame.camera_frame;
      job.T_W_C = T_W_C;
      job.T_C_D = T_C_D;
      job.received = frame.received;
      job.index = next_keyframe_index_++;

      geometry_msgs::PoseStamped pose;
      pose.header.frame_id = keyframe_path_.header.frame_id;
      pose.header.stamp = stamp;
      pose.pose = poseToMsg(T_W_C);
      keyframe_path_.header.stamp = stamp;
      keyframe_path_.poses.push_back(pose);
      if (keyframe_path_.poses.size() > kMaxPathPoses) {
        keyframe_path_.poses.erase(keyframe_path_.poses.begin());
      }
      publishers_->publishKeyframePath(keyframe_path_);
      on_keyframe_(std::move(job));
    }
    pending_.pop_front();
  }
}

}  // namespace mvod
