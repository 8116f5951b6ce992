#include "multiview_object_detection/ros/map_autosaver.h"

#include <ros/console.h>

#include <algorithm>
#include <chrono>
#include <cstring>
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

namespace {

constexpr int kFallbacks = 8;  // <name>-2.mvmap to <name>-9.mvmap

// path (a folder "<name>.mvmap") for index 0, its index-th fallback "<name>-<index + 1>.mvmap"
// else.
// `path` ends in .mvmap (the node resolves autosave_path through mapFolderPath).
std::string fallbackFolder(const std::string& path, int index) {
  if (index == 0) return path;
  const std::string stem = path.substr(0, path.size() - std::strlen(kMapFolderExtension));
  return stem + "-" + std::to_string(index + 1) + kMapFolderExtension;
}

}  // namespace

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

std::string MapAutosaver::path() const {
  const std::lock_guard<std::mutex> lock(folder_mutex_);
  return folder_.empty() ? path_ : folder_;
}

void MapAutosaver::publishState(const std::string& problem) {
  std::string folder;
  {
    const std::lock_guard<std::mutex> lock(folder_mutex_);
    folder = folder_;
  }
  stats_->update([&folder, &problem](ObjectDetectionStatistics& s) {
    s.autosave_folder = folder;
    s.autosave_problem = problem;
  });
}

bool MapAutosaver::claimFolder(int first, const std::string& why) {
  std::string reasons = why;
  for (int index = first; index <= kFallbacks; ++index) {
    const std::string folder = fallbackFolder(path_, index);
    const Status claimed = claim_.claim(folder);
    if (!claimed) {
      reasons += (reasons.empty() ? "" : "; ") + claimed.message();
      continue;
    }
    {
      const std::lock_guard<std::mutex> lock(folder_mutex_);
      folder_ = folder;
    }
    folder_index_ = index;
    if (index > 0) {
      fallback_problem_ = "autosave cannot use " + path_ + " (" + reasons +
                          "); the map is saved to " + folder + " instead: free or repair " + path_ +
                          ", or resume from the fallback (load_map_on_start or ~load_map " +
                          folder + ")";
      ROS_ERROR("%s", fallback_problem_.c_str());
    }
    publishState(fallback_problem_);
    return true;
  }
  claim_.release();
  {
    const std::lock_guard<std::mutex> lock(folder_mutex_);
    folder_.clear();
  }
  const std::string problem =
      "autosave off: no folder to save to (" + reasons + "; and " +
      fallbackFolder(path_, kFallbacks) +
      " was the last fallback): the map is not saved; ~save_map still works";
  ROS_ERROR("%s", problem.c_str());
  publishState(problem);
  return false;
}

void MapAutosaver::start() {
  if (claimFolder(0, "")) {
    const int removed = removeOrphanTemporaries(path() + "/map.json");
    if (removed > 0) {
      ROS_WARN("autosave: removed %d temporary file(s) that a killed save of %s left behind",
               removed, path().c_str());
    }
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
  if (folder_.empty()) return;  // no folder could be claimed (said at start)
  const auto start = std::chrono::steady_clock::now();
  MapFolderWriter::Report report;
  const int frames = stats_->get().frames_received;
  Status written = writeMapFile(folder_, *map, frames, &writer_, &report);
  if (!written) stats_->update([](ObjectDetectionStatistics& s) { ++s.autosave_failures; });
  if (!written && folder_index_ < kFallbacks) {
    // Not where it should go: to the next fallback, now, rather than nowhere.
    const std::string failed = folder_;
    if (claimFolder(folder_index_ + 1, "saving to " + failed + " failed: " + written.message())) {
      written = writeMapFile(folder_, *map, frames, &writer_, &report);
    }
  }
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (!written) {
    const std::string problem =
        "autosave to " + path() + " failed: " + written.message() +
        "; the previous autosave is kept, the next try in the next period (check the disk and the "
        "folder)";
    errorThrottled(problem);
    publishState(problem);
    return;
  }
  publishState(fallback_problem_);
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
                           std::to_string(report.folder_bytes) + " bytes) to " + folder_;
  if (final || !saved_once_) {
    saved_once_ = true;
    ROS_INFO("autosave%s: %s in %.1f ms", final ? " at shutdown" : " (the first)", what.c_str(),
             ms);
  } else {
    ROS_DEBUG("autosave: %s in %.1f ms", what.c_str(), ms);
  }
}

}  // namespace mvod
