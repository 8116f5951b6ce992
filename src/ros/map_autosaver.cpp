#include "multiview_object_detection/ros/map_autosaver.h"

#include <ros/console.h>

#include <algorithm>
#include <chrono>
#include <deque>
#include <filesystem>
#include <utility>
#include <vector>

#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/io/map_folder.h"
#include "multiview_object_detection/ros/throttled_log.h"

namespace mvod {

Status writeMapFile(const std::string& folder, const KeyframeWorker::MapSnapshot& map,
                    int frames_received, MapFolderWriter* writer, MapFolderWriter::Report* report) {
  MapSummary summary = map.summary;
  summary.frames = frames_received;
  MapFolderWriter local;
  return (writer != nullptr ? writer : &local)
      ->write(folder, map.objects, summary, map.history, report);
}

Status loadMapFile(const std::string& path, KeyframeWorker* worker, size_t* objects,
                   double timeout_s, std::map<int, std::string>* keyframe_files) {
  std::vector<MapObject> loaded;
  MapSummary summary;
  std::deque<KeyframeRecord> history;
  Status status = loadMap(path, Links::kRefuse, &loaded, &summary, &history, keyframe_files);
  if (status) status = worker->replaceMap(loaded, summary, std::move(history), timeout_s);
  if (status && objects != nullptr) *objects = loaded.size();
  return status;
}

MapAutosaver::MapAutosaver(std::string path, double period_s, const KeyframeWorker* worker,
                           SharedStatistics* stats)
    : path_(std::move(path)), period_s_(period_s), worker_(worker), stats_(stats) {}

MapAutosaver::~MapAutosaver() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void MapAutosaver::adoptLoadedMap(const std::string& folder,
                                  const std::map<int, std::string>& keyframe_files) {
  std::error_code error;
  if (keyframe_files.empty() || !std::filesystem::equivalent(folder, path_, error)) return;
  const std::shared_ptr<const KeyframeWorker::MapSnapshot> map = worker_->snapshot();
  if (map) writer_.adopt(path_, map->history, keyframe_files);
}

void MapAutosaver::start() {
  const int removed = removeOrphanTemporaries(path_ + "/map.json");
  if (removed > 0) {
    ROS_WARN("autosave: removed %d temporary file(s) that a killed save of %s left behind", removed,
             path_.c_str());
  }
  // The map as it starts (empty, or loaded) is not worth a save of its own.
  last_saved_ = worker_->snapshot();
  thread_ = std::thread(&MapAutosaver::loop, this);
}

void MapAutosaver::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stop_ && !thread_.joinable()) return;
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
  saveIfChanged(true);
}

void MapAutosaver::loop() {
  // At a fixed rate (a save's own time does not push the next one back), so the file is never older
  // than a period and one save; a save longer than the period is followed at once by the next.
  const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(period_s_));
  auto next = std::chrono::steady_clock::now() + period;
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stop_) {
    if (cv_.wait_until(lock, next, [this] { return stop_; })) break;
    next = std::max(next + period, std::chrono::steady_clock::now());
    lock.unlock();
    saveIfChanged(false);
    lock.lock();
  }
}

void MapAutosaver::saveIfChanged(bool final) {
  const std::shared_ptr<const KeyframeWorker::MapSnapshot> map = worker_->snapshot();
  // The same snapshot (owner) as the last save's: unchanged. A weak reference: holding the snapshot
  // for a period would hold every depth image and cut the history gave up since (its bound).
  if (!map || (!last_saved_.owner_before(map) && !map.owner_before(last_saved_))) return;
  const auto start = std::chrono::steady_clock::now();
  MapFolderWriter::Report report;
  const Status written =
      writeMapFile(path_, *map, stats_->get().frames_received, &writer_, &report);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (!written) {
    errorThrottled("autosave to " + path_ + " failed: " + written.message() +
                   "; the previous autosave is kept, the next try in the next period");
    stats_->update([](ObjectDetectionStatistics& s) { ++s.autosave_failures; });
    return;
  }
  last_saved_ = map;
  const int objects = static_cast<int>(map->objects.size());
  const double bytes = static_cast<double>(report.folder_bytes);
  const double written_bytes = static_cast<double>(report.bytes_written);
  stats_->update([ms, bytes, written_bytes](ObjectDetectionStatistics& s) {
    ++s.autosaves;
    s.autosave_ms = ms;
    s.autosave_bytes = bytes;
    s.autosave_written_bytes = written_bytes;
  });
  const std::string what = std::to_string(objects) + " objects, " +
                           std::to_string(report.keyframe_files_written) + " of " +
                           std::to_string(map->history.size()) + " keyframe files written (" +
                           std::to_string(report.bytes_written) + " of " +
                           std::to_string(report.folder_bytes) + " bytes) to " + path_;
  if (final || !saved_once_) {
    saved_once_ = true;
    ROS_INFO("autosave%s: %s in %.1f ms", final ? " at shutdown" : " (the first)", what.c_str(),
             ms);
  } else {
    ROS_DEBUG("autosave: %s in %.1f ms", what.c_str(), ms);
  }
}

}  // namespace mvod
