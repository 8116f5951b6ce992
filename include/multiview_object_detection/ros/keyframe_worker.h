// The node's heavy work, off the callback threads: keyframes wait in a bounded queue (the oldest is
// dropped when it is full, voxblox-style) and ONE worker thread runs the detector and
// ObjectMapper::processKeyframe on each, applying reconfigured settings between keyframes. The map
// lives here; the services reach it through the map functions below, under the same lock.
// Implemented in three files: keyframe_worker.cpp (queue, thread, one keyframe),
// keyframe_worker_changes.cpp (pose corrections, reconfigure), keyframe_worker_map.cpp (refinement,
// the map for the services).
#pragma once

#include <tf2_ros/buffer.h>

#include <atomic>
#include <condition_variable>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "multiview_object_detection/detectors/segmenter_factory.h"
#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/pipeline/object_mapper.h"
#include "multiview_object_detection/pipeline/types/class_priors.h"
#include "multiview_object_detection/ros/conversions.h"
#include "multiview_object_detection/ros/detections_buffer.h"
#include "multiview_object_detection/ros/object_detection_publishers.h"
#include "multiview_object_detection/ros/object_detection_statistics.h"
#include "multiview_object_detection/ros/pending_frames.h"
#include "multiview_object_detection/ros/runtime_config.h"

namespace mvod {

class KeyframeWorker {
 public:
  // What one refinement removed, and what is left.
  struct Refinement {
    int removed_atypical = 0;
    int removed_intersecting = 0;
    size_t objects_left = 0;
  };

  // `segmenter`: the detector (null for detector "topic", then `detections` is used);
  // `segmenter_injected`: given by the caller, never reloaded on reconfigure.
  KeyframeWorker(const ClassPriors& priors, std::unique_ptr<InstanceSegmenter> segmenter,
                 bool segmenter_injected, const RgbdTopics& topics, RuntimeConfig* config,
                 const tf2_ros::Buffer& tf_buffer, DetectionsBuffer* detections,
                 ObjectDetectionPublishers* publishers, SharedStatistics* stats);
  ~KeyframeWorker();

  KeyframeWorker(const KeyframeWorker&) = delete;
  KeyframeWorker& operator=(const KeyframeWorker&) = delete;

  void start();
  // Finishes the queued keyframes and joins the thread (stopNow() drops them). Idempotent.
  void stop();

  // Queues a keyframe (any thread, never blocks); the oldest is dropped when the queue is full.
  void enqueue(KeyframeJob job);
  // Queues corrected keyframe poses (any thread, never blocks): the worker applies them before its
  // next keyframe, or at once when idle (ObjectMapper::correctPoses). Corrections that arrive
  // before the worker took the previous ones merge with them (the latest pose per stamp), so a
  // long path published often costs one map rebuild per keyframe at most.
  void enqueueCorrections(std::vector<PoseCorrection> corrections);
  void clearQueue();
  // Cancels the keyframe in progress (~reset): it stops between its detections' stages, within
  // about one stage's time, and nothing of it reaches the map.
  void cancelCurrent();
  // Shutdown without waiting for the work in hand: drops the queue, cancels the keyframe in
  // progress, joins the thread.
  void stopNow();

  // The map as of the last finished keyframe or map change: reading it never waits for a keyframe
  // being processed (~get_objects and ~save_map answer at once).
  struct MapSnapshot {
    std::vector<MapObject> objects;
    MapSummary summary;  // all but `frames`
    // What the map follows corrections with (records share their depth and cuts: cheap copies).
    std::deque<KeyframeRecord> history;
    // The gravity-aligned output frame in the world frame (output_frame.h): the gravity and the
    // floor this map was built with.
    Eigen::Isometry3d T_W_O = Eigen::Isometry3d::Identity();
  };
  std::shared_ptr<const MapSnapshot> snapshot() const;
  std::vector<MapObject> objects() const;
  // The current map on the publishers' topics (in the output frame, with its TF).
  void publishMap(const ros::Time& stamp) const;
  // The objects and the summary for objects.json (all but `frames`).
  void mapSnapshot(std::vector<MapObject>* objects, MapSummary* summary,
                   std::deque<KeyframeRecord>* history = nullptr) const;
  // The map changes below wait for the keyframe being processed, at most `timeout_s` (< 0: as
  // long as it takes); past it they change nothing and return an error saying the worker is busy
  // (the services pass service_timeout_s).
  // Replaces the objects (~load_map); the keyframe count and gravity are kept. Refused (map
  // unchanged) when the ids are out of range or repeated. The keyframe history loaded with the map
  // replaces the mapper's (an empty one: the map's objects cannot follow corrections).
  Status replaceMap(const std::vector<MapObject>& objects, const MapSummary& summary,
                    std::deque<KeyframeRecord> history = {}, double timeout_s = -1.0);
  // Empties the map; ids keep counting. *removed: the number of objects removed.
  Status resetMap(double timeout_s, size_t* removed);
  // Sec. 3.5 on the current map.
  Status refine(const std::string& why, double timeout_s, Refinement* refinement);

 private:
  void workerLoop();
  void processKeyframe(const KeyframeJob& job);
  void applyCorrections(std::vector<PoseCorrection> corrections);
  // After a new database/fusion_voxel_size_m: says whether the map was fused again from the
  // history or the new grid applies to the next keyframes only, and publishes a map fused again.
  void reportNewGrid(const ObjectMapper::ReconfigureReport& report, double old_grid_m,
                     double new_grid_m);
  void applyPendingReconfigure();
  // Keeps the max_detections highest-scoring detections (in their order), counted and warned.
  void capDetections(int max_detections, const std::string& what,
                     std::vector<Detection2D>* detections);
  bool updateGravityFromTf(const std::string& what);
  // The map's lock, waiting at most timeout_s (< 0: unbounded); not owned when that passed (*busy
  // says why).
  std::unique_lock<std::timed_mutex> lockMap(double timeout_s, Status* busy) const;
  void refineLocked(const std::string& why);                               // needs mapper_mutex_
  void publishRefinementRemovals(ObjectMapper::RefinementReport* report);  // moves its objects
  void updateSnapshotLocked();                                             // needs mapper_mutex_

  const RgbdTopics topics_;
  RuntimeConfig* config_;
  const tf2_ros::Buffer& tf_buffer_;
  DetectionsBuffer* detections_;  // detector "topic" only
  ObjectDetectionPublishers* publishers_;
  SharedStatistics* stats_;
  const int max_queue_size_;      // processing_queue_size (fixed)
  const double max_queue_bytes_;  // processing_queue_max_mb (fixed)

  // Queue (queue_mutex_).
  std::mutex queue_mutex_;
  std::condition_variable queue_cv_;
  std::deque<KeyframeJob> queue_;
  std::size_t queue_bytes_ = 0;                           // the queued jobs' images
  std::map<double, PoseCorrection> pending_corrections_;  // by stamp, the latest pose
  bool stop_ = false;
  // Set by cancelCurrent(): the keyframe in progress stops between its stages (ObjectMapper).
  std::atomic<bool> cancel_{false};
  std::atomic<bool> shut_down_requested_{false};
  std::thread thread_;

  // The map (mapper_mutex_): the worker and the services.
  mutable std::timed_mutex mapper_mutex_;
  std::unique_ptr<ObjectMapper> mapper_;
  int removed_atypical_ = 0;
  int removed_gone_ = 0;  // by the existence evidence, for the saved map's summary
  int removed_intersecting_ = 0;

  // What the services read (snapshot_mutex_, innermost but for the statistics).
  mutable std::mutex snapshot_mutex_;
  std::shared_ptr<const MapSnapshot> snapshot_ = std::make_shared<MapSnapshot>();

  // The worker thread's own.
  std::unique_ptr<InstanceSegmenter> segmenter_;
  const bool segmenter_injected_;
  bool gravity_from_tf_known_ = false;
  // The last 100 processed keyframes': latency, detector time, geometry time (processKeyframe).
  std::deque<double> latencies_ms_;
  std::deque<double> detection_times_ms_;
  std::deque<double> geometry_times_ms_;
  void recordTimes(double latency_ms, double detection_ms, double geometry_ms);
};

}  // namespace mvod
