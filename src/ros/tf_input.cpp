#include "multiview_object_detection/ros/tf_input.h"

#include <string>

#include "multiview_object_detection/ros/input_guard.h"

namespace mvod {

TfInput::TfInput(tf2_ros::Buffer* buffer, SharedStatistics* stats)
    : buffer_(buffer), stats_(stats) {}

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
    // A static transform's stamp is not used for look-ups, but tf2 still does arithmetic on it.
    if (!acceptInputStamp(transform.header.stamp, what, stats_)) continue;
    runGuarded(what, stats_, [&] { buffer_->setTransform(transform, authority, is_static); });
  }
}

}  // namespace mvod
