#include "multiview_object_detection/ros/detections_buffer.h"

#include <algorithm>
#include <cmath>

#include "multiview_object_detection/ros/conversions.h"
#include "multiview_object_detection/ros/input_guard.h"
#include "multiview_object_detection/ros/throttled_log.h"

namespace mvod {
namespace {

using Clock = std::chrono::steady_clock;

constexpr size_t kMaxBufferedDetections = 300;
// Detections are matched to a keyframe by the colour image's stamp, which a detector copies.
constexpr double kDetectionStampToleranceS = 1e-3;

}  // namespace

void DetectionsBuffer::subscribe(ros::NodeHandle nh) {
  using Msg = multiview_object_detection::InstanceDetections;
  // A detector may run on some frames only: its silence is checked, not its rate.
  if (stats_ != nullptr) stats_->inputs().expect(nh.resolveName("detections"), false);
  sub_ = nh.subscribe<Msg>("detections", 30,
                           guardedCallback<Msg>(nh.resolveName("detections"), stats_,
                                                [this](const boost::shared_ptr<const Msg>& msg) {
                                                  detectionsCallback(msg);
                                                }));
}

void DetectionsBuffer::unsubscribe() { sub_.shutdown(); }

void DetectionsBuffer::wakeWaiting() { cv_.notify_all(); }

void DetectionsBuffer::dropAfter(const ros::Time& stamp) {
  std::lock_guard<std::mutex> lock(mutex_);
  dropAfterLocked(stamp);
}

void DetectionsBuffer::dropAfterLocked(const ros::Time& stamp) {
  while (!detections_.empty() && detections_.back()->header.stamp > stamp) detections_.pop_back();
}

void DetectionsBuffer::detectionsCallback(
    const multiview_object_detection::InstanceDetectionsConstPtr& msg) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!detections_.empty() &&
        (detections_.back()->header.stamp - msg->header.stamp).toSec() > kTimeJumpBackS) {
      warnThrottled("detections " + describeInput(topic(), msg->header) +
                    ": time jumped back; the buffered later detections are dropped");
      dropAfterLocked(msg->header.stamp + ros::Duration(kTimeJumpBackS));
    }
    const auto it = std::upper_bound(
        detections_.begin(), detections_.end(), msg->header.stamp,
        [](const ros::Time& stamp,
           const multiview_object_detection::InstanceDetectionsConstPtr& detections) {
          return stamp < detections->header.stamp;
        });
    detections_.insert(it, msg);
    while (detections_.size() > kMaxBufferedDetections) detections_.pop_front();
  }
  cv_.notify_all();
}

bool DetectionsBuffer::waitFor(const KeyframeJob& job, double max_age_s, const cv::Size& image_size,
                               const std::string& what, size_t max_detections,
                               std::vector<Detection2D>* detections) {
  const std_msgs::Header& header = job.msgs.color->header;
  const ros::Time stamp = header.stamp;
  const Clock::time_point deadline = job.received + std::chrono::duration_cast<Clock::duration>(
                                                        std::chrono::duration<double>(max_age_s));
  multiview_object_detection::InstanceDetectionsConstPtr match;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    while (true) {
      // Keyframes come in stamp order: detections older than this one are not needed any more.
      while (!detections_.empty() &&
             (detections_.front()->header.stamp - stamp).toSec() < -kDetectionStampToleranceS) {
        detections_.pop_front();
      }
      if (!detections_.empty() && std::abs((detections_.front()->header.stamp - stamp).toSec()) <=
                                      kDetectionStampToleranceS) {
        match = detections_.front();
        detections_.pop_front();
        break;
      }
      if (Clock::now() >= deadline || shut_down_) break;
      cv_.wait_until(lock, deadline);
    }
  }
  if (!match) {
    errorThrottled(what + " skipped: no detections with its stamp on '" + topic() +
                   "' within detections_max_age_s (" + std::to_string(max_age_s) + " s)");
    return false;
  }
  std::vector<std::string> warnings;
  size_t capped = 0;
  const Status converted = detectionsFromMsg(*match, image_size, topic(), detections, &warnings,
                                             max_detections, &capped);
  if (capped > 0 && stats_ != nullptr) {
    stats_->update([capped](ObjectDetectionStatistics& stats) {
      stats.detections_capped += static_cast<int>(capped);
    });
  }
  for (const std::string& warning : warnings) warnThrottled(warning);
  if (!converted) {
    errorThrottled(what + " skipped: " + converted.message());
    return false;
  }
  return true;
}

}  // namespace mvod
