#include <ros/console.h>

#include <algorithm>
#include <chrono>
#include <sstream>
#include <string>

#include "multiview_object_detection/pipeline/map/output_frame.h"
#include "multiview_object_detection/ros/keyframe_worker.h"

// KeyframeWorker, part 3: refinement and the map for the services (snapshots, replace, reset).
// Parts 1 and 2: keyframe_worker.cpp, keyframe_worker_changes.cpp.

namespace mvod {
namespace {

std::string idList(const std::vector<int>& ids) {
  std::ostringstream out;
  out << "[";
  for (size_t i = 0; i < ids.size(); ++i) out << (i > 0 ? ", " : "") << ids[i];
  out << "]";
  return out.str();
}

}  // namespace

void KeyframeWorker::refineLocked(const std::string& why) {
  ObjectMapper::RefinementReport report = mapper_->refine();
  removed_atypical_ += static_cast<int>(report.atypical_ids.size());
  removed_intersecting_ += static_cast<int>(report.intersecting_ids.size());
  stats_->update([this, &report](ObjectDetectionStatistics& stats) {
    stats.removed_atypical = removed_atypical_;
    stats.removed_intersecting = removed_intersecting_;
    stats.stage_times.refinement_ms = report.time_ms;
  });
  if (!report.atypical_ids.empty() || !report.intersecting_ids.empty()) {
    std::string merged;
    for (const auto& pair : report.merged_ids) {
      merged += (merged.empty() ? "" : ", ") + std::to_string(pair.first) + " into " +
                std::to_string(pair.second);
    }
    // Each atypical object with why: too large (neighbours taken as one), too small or thin.
    std::string atypical;
    for (size_t k = 0; k < report.atypical_ids.size(); ++k) {
      atypical += (k > 0 ? "; #" : "#") + std::to_string(report.atypical_ids[k]);
      if (k < report.atypical_reasons.size()) atypical += " " + report.atypical_reasons[k];
    }
    ROS_INFO("refinement (%s): removed atypical [%s], intersecting %s%s%s (%.1f ms)", why.c_str(),
             atypical.c_str(), idList(report.intersecting_ids).c_str(),
             merged.empty() ? "" : "; duplicates merged: ", merged.c_str(), report.time_ms);
  }
  publishRefinementRemovals(&report);
}

// Nothing the refinement removes leaves the map silently: each object goes out on
// ~removed_objects as it was, with why.
void KeyframeWorker::publishRefinementRemovals(ObjectMapper::RefinementReport* report) {
  if (report->removed.empty()) return;
  std::vector<MapObject> removed;
  std::vector<std::string> reasons;
  for (ObjectMapper::RemovedObject& entry : report->removed) {
    removed.push_back(std::move(entry.object));
    reasons.push_back("refinement: " + entry.reason);
  }
  publishers_->publishRemoved(removed, reasons,
                              gravityAlignedPose(mapper_->gravity(), mapper_->floorHeight_m()),
                              ros::Time::now());
}

// ---------------------------------------------------------------------------------------------
// The map, for the services

void KeyframeWorker::updateSnapshotLocked() {
  auto snapshot = std::make_shared<MapSnapshot>();
  snapshot->objects = databaseObjects(mapper_->database());
  snapshot->summary.keyframes = mapper_->keyframesProcessed();
  snapshot->summary.gravity_down_W = -mapper_->gravity().up;
  snapshot->summary.floor_height_m = mapper_->floorHeight_m();
  snapshot->T_W_O = gravityAlignedPose(mapper_->gravity(), mapper_->floorHeight_m());
  snapshot->summary.removed_atypical = removed_atypical_;
  snapshot->summary.removed_intersecting = removed_intersecting_;
  snapshot->summary.removed_gone = removed_gone_;
  snapshot->history = mapper_->history().records();
  const KeyframeHistory::Usage usage = mapper_->history().usage();
  stats_->update([&usage](ObjectDetectionStatistics& stats) {
    stats.history_mb = static_cast<double>(usage.bytes) / (1024.0 * 1024.0);
    stats.history_keyframes = usage.keyframes;
    stats.history_full_depth = usage.full_depth;
    stats.history_coarse_depth = usage.coarse_depth;
    stats.history_views_only = usage.views_only;
    stats.history_forgotten = usage.forgotten;
  });
  std::lock_guard<std::mutex> lock(snapshot_mutex_);
  snapshot_ = std::move(snapshot);
}

std::shared_ptr<const KeyframeWorker::MapSnapshot> KeyframeWorker::snapshot() const {
  std::lock_guard<std::mutex> lock(snapshot_mutex_);
  return snapshot_;
}

std::vector<MapObject> KeyframeWorker::objects() const { return snapshot()->objects; }

void KeyframeWorker::publishMap(const ros::Time& stamp) const {
  const std::shared_ptr<const MapSnapshot> map = snapshot();
  publishers_->publishMap(map->objects, map->T_W_O, stamp);
}

void KeyframeWorker::mapSnapshot(std::vector<MapObject>* objects, MapSummary* summary,
                                 std::deque<KeyframeRecord>* history) const {
  const std::shared_ptr<const MapSnapshot> map = snapshot();
  *objects = map->objects;
  *summary = map->summary;
  if (history != nullptr) *history = map->history;
}

std::unique_lock<std::timed_mutex> KeyframeWorker::lockMap(double timeout_s, Status* busy) const {
  std::unique_lock<std::timed_mutex> lock(mapper_mutex_, std::defer_lock);
  if (timeout_s < 0.0) {
    lock.lock();
  } else if (!lock.try_lock_for(std::chrono::duration<double>(timeout_s))) {
    std::ostringstream text;
    text << "busy: the keyframe in progress did not finish within service_timeout_s (" << timeout_s
         << " s); the map was not changed, try again";
    *busy = Status::Error(text.str());
  }
  return lock;
}

Status KeyframeWorker::replaceMap(const std::vector<MapObject>& objects, const MapSummary& summary,
                                  std::deque<KeyframeRecord> history, double timeout_s) {
  Status busy;
  const std::unique_lock<std::timed_mutex> lock = lockMap(timeout_s, &busy);
  if (!lock.owns_lock()) return busy;
  const Status replaced = mapper_->mutableDatabase().setObjects(objects);
  if (!replaced) return replaced;
  // The history may name objects refined away after its keyframes: no new object takes their ids
  // (a correction's replay would take the two for one).
  int largest_view_id = -1;
  for (const KeyframeRecord& record : history) {
    for (const RecordedView& view : record.views) {
      largest_view_id = std::max(largest_view_id, view.object_id);
    }
  }
  mapper_->mutableDatabase().reserveIdsBelow(largest_view_id + 1);
  mapper_->setHistory(std::move(history));
  mapper_->restoreFloor(summary.floor_height_m);
  removed_atypical_ = summary.removed_atypical;
  removed_intersecting_ = summary.removed_intersecting;
  removed_gone_ = summary.removed_gone;
  updateSnapshotLocked();
  return Status::Ok();
}

Status KeyframeWorker::resetMap(double timeout_s, size_t* removed) {
  Status busy;
  const std::unique_lock<std::timed_mutex> lock = lockMap(timeout_s, &busy);
  if (!lock.owns_lock()) return busy;
  *removed = mapper_->database().size();
  mapper_->reset();
  removed_atypical_ = 0;
  removed_intersecting_ = 0;
  removed_gone_ = 0;
  updateSnapshotLocked();
  return Status::Ok();
}

Status KeyframeWorker::refine(const std::string& why, double timeout_s, Refinement* refinement) {
  Status busy;
  const std::unique_lock<std::timed_mutex> lock = lockMap(timeout_s, &busy);
  if (!lock.owns_lock()) return busy;
  const int atypical_before = removed_atypical_;
  const int intersecting_before = removed_intersecting_;
  refineLocked(why);
  refinement->removed_atypical = removed_atypical_ - atypical_before;
  refinement->removed_intersecting = removed_intersecting_ - intersecting_before;
  refinement->objects_left = mapper_->database().size();
  updateSnapshotLocked();
  return Status::Ok();
}

}  // namespace mvod
