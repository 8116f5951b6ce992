#include "multiview_object_detection/ros/map_autosaver.h"

#include <ros/console.h>

#include <algorithm>
#include <chrono>
#include <deque>
#include <utility>
#include <vector>

#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/ros/throttled_log.h"

namespace mvod {

Status writeMapFile(const std::string& path, const KeyframeWorker::MapSnapshot& map,
                    int frames_received, size_t* bytes, MapEncodingCache* cache) {
  MapSummary summary = map.summary;
  summary.frames = frames_received;
  const std::string text = objectsToJson(map.objects, summary, true, &map.history, cache);
  if (bytes != nullptr) *bytes = text.size();
  return writeFileAtomic(path, text);
}

Status loadMapFile(const std::string& path, KeyframeWorker* worker, size_t* objects,
                   double timeout_s) {
  std::string text;
  std::vector<MapObject> loaded;
  MapSummary summary;
  std::deque<KeyframeRecord> history;
  Status status = readFile(path, &text, kDefaultMaxFileBytes, Links::kRefuse);
  if (status) status = objectsFromJson(text, &loaded, &summary, &history);
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

void MapAutosaver::start() {
  const int removed = removeOrphanTemporaries(path_);
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
  // A map loaded at start is encoded once now, in the background, so that its first save costs
  // what the later ones do (only the keyframes recorded since).
  if (last_saved_ && !last_saved_->history.empty()) {
    objectsToJson(last_saved_->objects, last_saved_->summary, true, &last_saved_->history,
                  &encodings_);
  }
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
  if (!map || map == last_saved_) return;
  const auto start = std::chrono::steady_clock::now();
  size_t bytes = 0;
  const Status written =
      writeMapFile(path_, *map, stats_->get().frames_received, &bytes, &encodings_);
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
  stats_->update([ms, bytes](ObjectDetectionStatistics& s) {
    ++s.autosaves;
    s.autosave_ms = ms;
    s.autosave_bytes = static_cast<double>(bytes);
  });
  if (final || !saved_once_) {
    saved_once_ = true;
    ROS_INFO("autosave%s: %d objects, %zu bytes to %s in %.1f ms",
             final ? " at shutdown" : " (the first)", objects, bytes, path_.c_str(), ms);
  } else {
    ROS_DEBUG("autosave: %d objects, %zu bytes to %s in %.1f ms", objects, bytes, path_.c_str(),
              ms);
  }
}

}  // namespace mvod
