#include <ros/console.h>

#include <string>
#include <utility>

#include "multiview_object_detection/ros/keyframe_worker.h"
#include "multiview_object_detection/ros/throttled_log.h"

// KeyframeWorker, part 2: what changes the map besides a keyframe (keyframe pose corrections, a
// reconfigure that needs the mapper or the detector rebuilt). Parts 1 and 3: keyframe_worker.cpp
// (the queue and one keyframe), keyframe_worker_map.cpp (refinement and the map for the services).

namespace mvod {

void KeyframeWorker::applyCorrections(std::vector<PoseCorrection> corrections) {
  ObjectMapper::CorrectionReport report;
  Status applied;
  {
    std::lock_guard<std::timed_mutex> lock(mapper_mutex_);
    applied = mapper_->correctPoses(corrections, &report);
    if (applied && report.keyframes_moved > 0) updateSnapshotLocked();
  }
  if (!applied) {
    errorThrottled("keyframe poses refused: " + applied.message());
    return;
  }
  if (report.ignored) {
    warnThrottled(
        "keyframe poses ignored: the paper's method (or corrections/enable false) keeps "
        "no keyframe history, so the map cannot follow the SLAM's corrections");
    return;
  }
  if (report.unmatched > 0) {
    warnThrottled("keyframe poses: " + std::to_string(report.unmatched) + " of " +
                  std::to_string(corrections.size()) +
                  " stamps match no keyframe of the map (within corrections/stamp_tolerance_s; "
                  "run the node on the SLAM's keyframes, keyframe_mode topic)");
  }
  stats_->update([&report](ObjectDetectionStatistics& stats) {
    stats.removed_gone += report.objects_gone;
    stats.removed_by_corrections += static_cast<int>(report.removed.size());
    ++stats.corrections_applied;
    stats.keyframes_corrected += report.keyframes_moved;
    stats.keyframe_poses_unmatched += report.unmatched;
    stats.correction_ms = report.time_ms;
  });
  if (report.keyframes_moved == 0) return;
  ROS_INFO(
      "keyframe poses corrected: %d keyframes moved, %d views fused again, objects %d -> %d, "
      "%zu removed (%.1f ms)",
      report.keyframes_moved, report.views_replayed, report.objects_before, report.objects_after,
      report.removed.size(), report.time_ms);
  std::vector<MapObject> removed;
  std::vector<std::string> reasons;
  for (const ObjectMapper::RemovedObject& entry : report.removed) {
    ROS_INFO("keyframe poses corrected: %s #%d removed: %s", entry.object.class_name.c_str(),
             entry.object.id, entry.reason.c_str());
    removed.push_back(entry.object);
    reasons.push_back(entry.reason);
  }
  if (report.objects_restored > 0) {
    ROS_INFO(
        "keyframe poses corrected: %d objects kept as they were (none of their views moved, so "
        "the correction cannot explain their removal)",
        report.objects_restored);
  }
  const ros::Time now = ros::Time::now();
  publishers_->publishRemoved(removed, reasons, snapshot()->T_W_O, now);
  publishMap(now);
}

void KeyframeWorker::applyPendingReconfigure() {
  bool mapper_changed = false;
  bool segmenter_changed = false;
  const RuntimeConfig::Config config = config_->takeChanges(&mapper_changed, &segmenter_changed);
  if (mapper_changed) {
    ObjectMapper::ReconfigureReport report;
    double old_grid_m = 0.0;
    double new_grid_m = 0.0;
    {
      std::lock_guard<std::timed_mutex> lock(mapper_mutex_);
      ObjectMapper::Config mapper_config = config.mapperConfig();
      mapper_config.gravity_down_W = mapper_->config().gravity_down_W;  // not reconfigurable
      old_grid_m = mapper_->config().database.fusion_voxel_size_m;
      new_grid_m = mapper_config.database.fusion_voxel_size_m;
      const Status updated = mapper_->updateConfig(mapper_config, &report);
      if (!updated)
        ROS_ERROR("reconfigured mapper settings refused: %s", updated.message().c_str());
      if (report.fused_again) updateSnapshotLocked();
    }
    reportNewGrid(report, old_grid_m, new_grid_m);
  }
  if (segmenter_changed && config.detector != "topic" && !segmenter_injected_) {
    std::unique_ptr<InstanceSegmenter> segmenter;
    const Status created = createInstanceSegmenter(config.segmenterOptions(), &segmenter);
    if (created) {
      segmenter_ = std::move(segmenter);
      ROS_INFO("detector reloaded with score_threshold %.3f",
               config.segmenterOptions().score_threshold);
    } else {
      ROS_ERROR("detector reload failed, the previous one is kept: %s", created.message().c_str());
    }
  }
}

void KeyframeWorker::reportNewGrid(const ObjectMapper::ReconfigureReport& report, double old_grid_m,
                                   double new_grid_m) {
  if (report.next_fusions_only) {
    ROS_WARN(
        "database/fusion_voxel_size_m %g -> %g m applies to the next keyframes only: there is no "
        "keyframe history to fuse the map again from (the paper's method, or corrections/enable "
        "false); each object moves to the new voxel size when a detection is next fused into it",
        old_grid_m, new_grid_m);
    return;
  }
  if (!report.fused_again) return;
  ROS_INFO(
      "database/fusion_voxel_size_m %g -> %g m: the map was fused again from the keyframe history "
      "at the new voxel size, as if it had been used from the start: objects %d -> %d (%.1f ms)",
      old_grid_m, new_grid_m, report.objects_before, report.objects_after, report.time_ms);
  std::vector<MapObject> removed;
  std::vector<std::string> reasons;
  for (const ObjectMapper::RemovedObject& entry : report.removed) {
    ROS_INFO("%s #%d removed: %s", entry.object.class_name.c_str(), entry.object.id,
             entry.reason.c_str());
    removed.push_back(entry.object);
    reasons.push_back(entry.reason);
  }
  const ros::Time now = ros::Time::now();
  publishers_->publishRemoved(removed, reasons, snapshot()->T_W_O, now);
  publishMap(now);
}

}  // namespace mvod
