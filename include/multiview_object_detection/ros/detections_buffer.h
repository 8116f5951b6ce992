// detector "topic": instance detections from an external detector node, buffered by stamp until the
// worker takes the ones for its keyframe (matched by the colour image's stamp, which a detector
// copies).
#pragma once

#include <multiview_object_detection/InstanceDetections.h>
#include <ros/ros.h>

#include <atomic>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/detection.h"
#include "multiview_object_detection/ros/object_detection_statistics.h"
#include "multiview_object_detection/ros/pending_frames.h"

namespace mvod {

class DetectionsBuffer {
 public:
  // `shut_down` set: waitFor() gives up (wake it with wakeWaiting()).
  DetectionsBuffer(const std::atomic<bool>& shut_down, SharedStatistics* stats)
      : shut_down_(shut_down), stats_(stats) {}

  DetectionsBuffer(const DetectionsBuffer&) = delete;
  DetectionsBuffer& operator=(const DetectionsBuffer&) = delete;

  void subscribe(ros::NodeHandle nh);
  void unsubscribe();
  std::string topic() const { return sub_.getTopic(); }

  // Waits until max_age_s after the keyframe was received for the detections with its stamp and
  // converts them for an image of `image_size`; false (logged, naming the keyframe as `what`) when
  // none came or they are malformed. Keyframes must come in stamp order: older detections are
  // discarded.
  // Of more than max_detections, the highest-scoring are converted (counted in `stats`).
  bool waitFor(const KeyframeJob& job, double max_age_s, const cv::Size& image_size,
               const std::string& what, size_t max_detections,
               std::vector<Detection2D>* detections);
  void wakeWaiting();
  // Drops the buffered detections stamped after `stamp` (a zero stamp: all of them); called when
  // time jumped back and on ~reset.
  void dropAfter(const ros::Time& stamp);

 private:
  void detectionsCallback(const multiview_object_detection::InstanceDetectionsConstPtr& msg);
  void dropAfterLocked(const ros::Time& stamp);  // needs mutex_

  const std::atomic<bool>& shut_down_;
  SharedStatistics* stats_;
  ros::Subscriber sub_;

  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<multiview_object_detection::InstanceDetectionsConstPtr> detections_;  // by stamp
};

}  // namespace mvod
