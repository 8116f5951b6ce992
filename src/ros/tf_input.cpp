#include "multiview_object_detection/ros/tf_input.h"

#include <string>

#include "multiview_object_detection/ros/input_guard.h"

namespace mvod {

TfInput::TfInput(tf2_ros::Buffer* buffer, SharedStatistics* stats, TfStampCheck* stamp_check)
    : buffer_(buffer), stats_(stats), stamp_check_(stamp_check) {}

TfInput::~TfInput() {
  if (spinner_) spinner_->stop();
  tf_sub_.shutdown();
  tf_static_sub_.shutdown();
}

void TfInput::start(const ros::NodeHandle& nh) {
  ros::NodeHandle tf_nh(nh);
  tf_nh.setCallbackQueue(&queue_);
  using Event = ros::MessageEvent<const tf2_msgs::TFMessage>;
  tf_sub_ = tf_nh.subscribe<tf2_msgs::TFMessage>(
      "/tf", 100,
      boost::function<void(const Event&)>([this](const Event& e) { callback(e, false); }));
  tf_static_sub_ = tf_nh.subscribe<tf2_msgs::TFMessage>(
      "/tf_static", 100,
      boost::function<void(const Event&)>([this](const Event& e) { callback(e, true); }));
  spinner_ = std::make_unique<ros::AsyncSpinner>(1, &queue_);
  spinner_->start();
}

void TfInput::callback(const ros::MessageEvent<const tf2_msgs::TFMessage>& event, bool is_static) {
  const std::string topic = is_static ? "/tf_static" : "/tf";
  const std::string authority = event.getPublisherName();
  const tf2_msgs::TFMessage& msg = *event.getConstMessage();
  for (const geometry_msgs::TransformStamped& transform : msg.transforms) {
    const std::string what = "transform '" + transform.header.frame_id + "' <- '" +
                             transform.child_frame_id + "' on " + topic + " from " + authority;
    // A static transform's stamp is not used for look-ups, but tf2 still does arithmetic on it:
    // past 2038 it is refused, ahead of the node's clock it is not (a static publisher on the wall
    // clock beside a node on a bag's).
    if (!acceptInputStamp(transform.header.stamp, what, stats_, !is_static)) continue;
    runGuarded(what, stats_, [&] { buffer_->setTransform(transform, authority, is_static); });
    if (stamp_check_ != nullptr && !is_static) {
      stamp_check_->addTransform(transform.header.frame_id, transform.child_frame_id,
                                 transform.header.stamp.toSec(), ros::Time::now().toSec());
    }
  }
  if (stamp_check_ != nullptr && !is_static) judgeStamps();
}

void TfInput::judgeStamps() {
  const ros::WallTime now = ros::WallTime::now();
  if ((now - last_judged_).toSec() < 1.0) return;
  last_judged_ = now;
  std::string problem = stamp_check_->problem();
  if (problem == stamp_problem_) return;
  if (!problem.empty()) {
    ROS_WARN("%s", problem.c_str());
  } else {
    ROS_INFO("TF from the SLAM carries its images' stamps again");
  }
  stamp_problem_ = problem;
  stats_->update(
      [&problem](ObjectDetectionStatistics& stats) { stats.tf_stamp_problem = problem; });
}

}  // namespace mvod
