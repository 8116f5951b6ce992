// The node's counters: each stage counts its own, /diagnostics and the tests read them.
#pragma once

#include <mutex>
#include <string>

#include "multiview_object_detection/pipeline/object_mapper.h"
#include "multiview_object_detection/ros/input_monitor.h"

namespace mvod {

// Counters reported on /diagnostics (and read by tests).
struct ObjectDetectionStatistics {
  int frames_received = 0;
  int frames_rejected = 0;  // bad encoding, size, camera_info, out-of-order stamp
  // Lost before the node: gaps in the colour images' sequence numbers or stamps (FrameGaps).
  int frames_lost = 0;
  int pose_failures = 0;  // no TF / pose in time, or an invalid pose
  // The last reasons given for those two (the map status on /diagnostics names them).
  std::string last_frame_rejection;
  std::string last_pose_failure;
  int time_jumps = 0;           // input stamps jumped back by more than 1 s (buffers cleared)
  int detections_capped = 0;    // detections beyond max_detections_per_frame, dropped
  int stamps_refused = 0;       // any input stamped past 2038 or far ahead of the clock
  int callback_exceptions = 0;  // exceptions caught in callbacks and the worker (inputs dropped)
  int keyframes_selected = 0;
  int keyframes_dropped = 0;    // the processing queue was full
  int keyframes_cancelled = 0;  // by ~reset or shutdown while in progress
  int keyframes_processed = 0;  // went through ObjectMapper::processKeyframe
  int keyframes_failed = 0;     // conversion, detector or mapper error; no detections in time
  int queue_length = 0;
  double queue_mb = 0.0;  // the queued keyframes' images
  int objects = 0;
  int removed_atypical = 0;
  int removed_intersecting = 0;
  int removed_gone = 0;            // the existence evidence showed them gone
  int removed_by_corrections = 0;  // a pose correction fused them into others or showed them gone
  // Keyframes whose depth contradicted most of the map (a sensor or SLAM fault): not fused, no
  // votes.
  int keyframes_faulty = 0;
  bool waiting_for_gravity = false;
  // SLAM corrections (keyframe_poses): messages received, poses refused (NaN, not unit, unknown
  // frame), corrections applied, keyframes moved, poses that matched no keyframe; the last
  // correction's time.
  int keyframe_pose_messages = 0;
  int keyframe_poses_refused = 0;
  int corrections_applied = 0;
  int keyframes_corrected = 0;
  int keyframe_poses_unmatched = 0;
  double correction_ms = 0.0;
  // The keyframe history (corrections/max_memory_mb): its size, and how many keyframes keep their
  // depth, a coarser depth, only their views, or were forgotten.
  double history_mb = 0.0;
  int history_keyframes = 0;
  int history_full_depth = 0;
  int history_coarse_depth = 0;
  int history_views_only = 0;
  int history_forgotten = 0;
  // Autosave: saves written and failed; the last one's time and size.
  int autosaves = 0;
  int autosave_failures = 0;
  double autosave_ms = 0.0;
  double autosave_bytes = 0.0;          // the map as saved (the whole folder)
  double autosave_written_bytes = 0.0;  // what the last save wrote (new keyframe files, map.json)
  std::string autosave_folder;          // where the saves go now (empty: autosave off)
  // The SLAM's TF looks stamped when published, not with its images' stamps (TfStampCheck);
  // empty while it looks right.
  std::string tf_stamp_problem;
  // Why the autosave is not where it should be, or failing, and what to do; empty when it is well.
  std::string autosave_problem;
  double detection_ms = 0.0;  // last keyframe
  StageTimes stage_times;     // last keyframe
  // From a keyframe's images arriving to its objects being published (queueing, pose wait,
  // detection and mapping): the last one and the median of the last 100.
  double latency_ms = 0.0;
  double latency_median_ms = 0.0;
  // The detector's time and the geometry's (processKeyframe's total) per keyframe: medians of the
  // last 100 processed.
  double detection_median_ms = 0.0;
  double keyframe_total_median_ms = 0.0;
};

// The counters behind one mutex, written from the callback, worker and service threads. The mutex
// is the innermost lock of the node: update() may be called with any other lock held, and the
// function given to it takes none.
class SharedStatistics {
 public:
  ObjectDetectionStatistics get() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return stats_;
  }

  // Returns what `change` returns (e.g. the new value of a counter).
  template <typename Change>
  auto update(Change&& change) {
    std::lock_guard<std::mutex> lock(mutex_);
    return change(stats_);
  }

  // Arrivals per input, for the stale and rate checks on /diagnostics (its own lock).
  InputMonitor& inputs() { return inputs_; }
  const InputMonitor& inputs() const { return inputs_; }

 private:
  mutable std::mutex mutex_;
  ObjectDetectionStatistics stats_;
  InputMonitor inputs_;
};

}  // namespace mvod
