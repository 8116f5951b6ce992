#include "multiview_object_detection/ros/rgbd_input.h"

#include <boost/bind/bind.hpp>
#include <utility>

#include "multiview_object_detection/ros/throttled_log.h"

namespace mvod {

RgbdInput::RgbdInput(const ros::NodeHandle& nh, const ros::NodeHandle& nh_private,
                     const ObjectDetectionRosConfig& config, SharedStatistics* stats,
                     const std::atomic<bool>& shut_down)
    : nh_(nh), nh_private_(nh_private), config_(config), stats_(stats), shut_down_(shut_down) {
  topics_.depth = config_.depth_registered ? "depth_registered/image_rect" : "depth/image_rect";
  // Messages name the inputs as remapped.
  topics_.color = nh_.resolveName(topics_.color);
  topics_.depth = nh_.resolveName(topics_.depth);
  topics_.color_info = nh_.resolveName(topics_.color_info);
  topics_.depth_info = nh_.resolveName(topics_.depth_info);
  it_ = std::make_unique<image_transport::ImageTransport>(nh_);
}

void RgbdInput::subscribe(FrameCallback callback) {
  callback_ = std::move(callback);
  const int queue_size = config_.queue_size;
  const image_transport::TransportHints hints("raw", ros::TransportHints(), nh_private_);
  color_sub_.subscribe(*it_, topics_.color, queue_size, hints);
  depth_sub_.subscribe(*it_, topics_.depth, queue_size, hints);
  color_info_sub_.subscribe(nh_, topics_.color_info, queue_size);
  stats_->inputs().expect(topics_.color, true);
  stats_->inputs().expect(topics_.depth, true);
  stats_->inputs().expect(topics_.color_info, true);
  color_stamps_ = std::make_unique<StampFilter<Image>>(topics_.color, stats_);
  depth_stamps_ = std::make_unique<StampFilter<Image>>(topics_.depth, stats_);
  color_info_stamps_ = std::make_unique<StampFilter<CameraInfo>>(topics_.color_info, stats_);
  color_stamps_->connectInput(color_sub_);
  depth_stamps_->connectInput(depth_sub_);
  color_info_stamps_->connectInput(color_info_sub_);
  if (!config_.depth_registered) {
    depth_info_sub_.subscribe(nh_, topics_.depth_info, queue_size);
    stats_->inputs().expect(topics_.depth_info, true);
    depth_info_stamps_ = std::make_unique<StampFilter<CameraInfo>>(topics_.depth_info, stats_);
    depth_info_stamps_->connectInput(depth_info_sub_);
  }
  const auto jump_back = [this](const std::string& topic, const ros::Time& last,
                                const ros::Time& now) { restartSynchronizer(topic, last, now); };
  color_stamps_->onJumpBack(jump_back);
  depth_stamps_->onJumpBack(jump_back);
  color_info_stamps_->onJumpBack(jump_back);
  if (depth_info_stamps_) depth_info_stamps_->onJumpBack(jump_back);
  makeSynchronizer();
}

void RgbdInput::makeSynchronizer() {
  // The old one first: its destructor disconnects it from the stamp filters.
  approx_sync3_.reset();
  exact_sync3_.reset();
  approx_sync4_.reset();
  exact_sync4_.reset();
  const int queue_size = config_.queue_size;
  using boost::placeholders::_1;
  using boost::placeholders::_2;
  using boost::placeholders::_3;
  using boost::placeholders::_4;
  if (config_.depth_registered) {
    const auto callback =
        boost::bind(&RgbdInput::rgbdCallback, this, _1, _2, _3, sensor_msgs::CameraInfoConstPtr());
    if (config_.exact_sync) {
      exact_sync3_ = std::make_unique<message_filters::Synchronizer<ExactPolicy3>>(
          ExactPolicy3(queue_size), *color_stamps_, *depth_stamps_, *color_info_stamps_);
      exact_sync3_->registerCallback(callback);
    } else {
      approx_sync3_ = std::make_unique<message_filters::Synchronizer<ApproxPolicy3>>(
          ApproxPolicy3(queue_size), *color_stamps_, *depth_stamps_, *color_info_stamps_);
      approx_sync3_->registerCallback(callback);
    }
    return;
  }
  const auto callback = boost::bind(&RgbdInput::rgbdCallback, this, _1, _2, _3, _4);
  if (config_.exact_sync) {
    exact_sync4_ = std::make_unique<message_filters::Synchronizer<ExactPolicy4>>(
        ExactPolicy4(queue_size), *color_stamps_, *depth_stamps_, *color_info_stamps_,
        *depth_info_stamps_);
    exact_sync4_->registerCallback(callback);
  } else {
    approx_sync4_ = std::make_unique<message_filters::Synchronizer<ApproxPolicy4>>(
        ApproxPolicy4(queue_size), *color_stamps_, *depth_stamps_, *color_info_stamps_,
        *depth_info_stamps_);
    approx_sync4_->registerCallback(callback);
  }
}

void RgbdInput::restartSynchronizer(const std::string& topic, const ros::Time& last,
                                    const ros::Time& now) {
  // The synchroniser holds the old stream's last messages: matched against the new stream's
  // earlier ones they would pair frames seconds apart, and message_filters would warn "Messages
  // of type N arrived out of order" (issue 56). The inputs come on one callback thread, so no
  // message is inside the synchroniser now.
  warnThrottled("time went back on '" + topic + "' (" + std::to_string(last.toSec()) + " -> " +
                std::to_string(now.toSec()) +
                " s: a bag played again, or the clock reset): the RGB-D synchroniser starts "
                "afresh; the unmatched messages of before are dropped");
  for (auto* filter : {color_stamps_.get(), depth_stamps_.get()}) filter->forgetLastStamp();
  for (auto* filter : {color_info_stamps_.get(), depth_info_stamps_.get()}) {
    if (filter != nullptr) filter->forgetLastStamp();
  }
  makeSynchronizer();
}

void RgbdInput::unsubscribe() {
  color_sub_.unsubscribe();
  depth_sub_.unsubscribe();
  color_info_sub_.unsubscribe();
  depth_info_sub_.unsubscribe();
}

void RgbdInput::rgbdCallback(const sensor_msgs::ImageConstPtr& color,
                             const sensor_msgs::ImageConstPtr& depth,
                             const sensor_msgs::CameraInfoConstPtr& color_info,
                             const sensor_msgs::CameraInfoConstPtr& depth_info) {
  if (shut_down_) return;
  const int missing = color ? gaps_.add(color->header.seq, color->header.stamp.toSec()) : 0;
  stats_->update([missing](ObjectDetectionStatistics& stats) {
    ++stats.frames_received;
    stats.frames_lost += missing;
  });
  if (missing > 0) {
    warnThrottled(
        std::to_string(missing) + " frame(s) lost just before the colour image stamped " +
        std::to_string(color->header.stamp.toSec()) +
        " (gaps in its sequence numbers or stamps): the subscriber queue was full (the node "
        "too slow for the stream), or the network or the driver dropped them; /diagnostics "
        "counts them ('frames lost before the node')");
  }
  auto reject = [this](const std::string& text) {
    errorThrottled(text);
    stats_->update([&text](ObjectDetectionStatistics& stats) {
      ++stats.frames_rejected;
      stats.last_frame_rejection = text;
    });
  };
  PendingFrame frame;
  frame.msgs.color = color;
  frame.msgs.depth = depth;
  frame.msgs.color_info = color_info;
  frame.msgs.depth_info = depth_info;
  frame.received = std::chrono::steady_clock::now();
  const Status checked = checkRgbdMessages(frame.msgs, topics_);
  if (!checked) {
    reject("RGB-D input rejected: " + checked.message());
    return;
  }
  for (const auto& [info, topic] : {std::make_pair(color_info, topics_.color_info),
                                    std::make_pair(depth_info, topics_.depth_info)}) {
    if (!info) continue;
    const std::string distortion = distortionWarning(*info, topic);
    if (!distortion.empty()) warnThrottled(distortion);
  }
  frame.camera_frame = config_.camera_frame.empty() ? color->header.frame_id : config_.camera_frame;
  if (config_.pose_source == "tf" && frame.camera_frame.empty()) {
    reject("RGB-D input rejected: " + describeInput(topics_.color, color->header) +
           " has no frame_id and camera_frame is not set: the camera pose cannot be looked up");
    return;
  }
  // Stamp order and the pose are the keyframe buffer's business.
  callback_(std::move(frame));
}

}  // namespace mvod
