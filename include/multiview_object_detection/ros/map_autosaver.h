// Autosave: the map written to its folder (map_folder.h) in the background, so that a crash, an OOM
// kill or a power cut loses at most one period of mapping. Every autosave_period_s the saver takes
// the worker's current snapshot (a shared pointer: the worker is never held up by the save) and, if
// the map changed since the last save, writes it: the objects, and the keyframe files that are new
// or changed since the last save (the folder always holds a whole map, old or new). stop() saves
// once more (shutdown, SIGINT, SIGTERM).
#pragma once

#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "multiview_object_detection/io/map_folder.h"
#include "multiview_object_detection/pipeline/types/common.h"
#include "multiview_object_detection/ros/keyframe_worker.h"
#include "multiview_object_detection/ros/object_detection_statistics.h"

namespace mvod {

// Writes `map` to the map folder `folder` as ~save_map does (with clouds and the keyframe history);
// `writer` (may be null: a new one, which writes every keyframe file) reuses what it wrote before;
// `report` (may be null): what was written.
Status writeMapFile(const std::string& folder, const KeyframeWorker::MapSnapshot& map,
                    int frames_received, MapFolderWriter* writer = nullptr,
                    MapFolderWriter::Report* report = nullptr);

// Reads the map at `path` (resolved: a map folder or a single-file map of 0.9.x) into the worker,
// replacing its map (~load_map, load_map_on_start); on any error the worker's map is kept.
// `objects` (may be null): how many; `keyframe_files` (may be null): as loadMap's.
Status loadMapFile(const std::string& path, KeyframeWorker* worker, size_t* objects = nullptr,
                   double timeout_s = -1.0, std::map<int, std::string>* keyframe_files = nullptr);

class MapAutosaver {
 public:
  // `path`: the map folder, resolved, absolute; `period_s` > 0.
  MapAutosaver(std::string path, double period_s, const KeyframeWorker* worker,
               SharedStatistics* stats);
  ~MapAutosaver();
  MapAutosaver(const MapAutosaver&) = delete;
  MapAutosaver& operator=(const MapAutosaver&) = delete;

  const std::string& path() const { return path_; }
  // Before start(): the worker's map was just loaded from `folder` (load_map_on_start), whose
  // keyframe files were `keyframe_files`. When that is this saver's folder, its saves reuse them
  // (a resumed node does not write its whole history again at its first save).
  void adoptLoadedMap(const std::string& folder, const std::map<int, std::string>& keyframe_files);
  // Removes what an earlier, killed process's save left beside the file, then starts the thread.
  void start();
  // Joins the thread, then saves the map if it changed since the last save. Idempotent.
  void stop();

 private:
  void loop();
  // `final`: the save at stop(), logged at INFO with its size and time.
  void saveIfChanged(bool final);

  const std::string path_;
  const double period_s_;
  const KeyframeWorker* worker_;
  SharedStatistics* stats_;
  std::weak_ptr<const KeyframeWorker::MapSnapshot> last_saved_;  // the saver's thread only
  MapFolderWriter writer_;                                       // the saver's thread only
  bool saved_once_ = false;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace mvod
