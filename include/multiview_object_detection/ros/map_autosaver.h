// Autosave: the map written to its folder (map_folder.h) in the background, so that a crash, an OOM
// kill or a power cut loses at most one period of mapping. Every autosave_period_s the saver takes
// the worker's current snapshot (a shared pointer: the worker is never held up by the save) and, if
// the map changed since the last save, writes it: the objects, and the keyframe files that are new
// or changed since the last save (the folder always holds a whole map, old or new). stop() saves
// once more (shutdown, SIGINT, SIGTERM).
//
// The saver claims its folder for the node's life (MapFolderClaim). A folder another node claimed,
// or one a save cannot write (a stray .lock directory, a keyframes/ link, a full or read-only
// disk), is not the end of saving: the map goes to the first fallback beside it that it can claim
// and write, "<name>-2.mvmap" to "<name>-9.mvmap", with an ERROR that names both and what to do
// (statistics: autosave_folder, autosave_problem).
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

  // The folder asked for (before start()), or the one the saves go to now (after).
  std::string path() const;
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
  // Claims the first folder it can of path_ and its fallbacks, from the `first`-th (0: path_);
  // `why`: what went wrong with the one before, for the message. False: none could be claimed.
  bool claimFolder(int first, const std::string& why);
  // Statistics' autosave_folder and autosave_problem.
  void publishState(const std::string& problem);

  const std::string path_;
  std::string folder_;    // where the saves go: path_ or a fallback (the saver's thread only)
  int folder_index_ = 0;  // 0: path_; n: its n-th fallback
  std::string
      fallback_problem_;  // why the saves go to a fallback, and what to do ("": they do not)
  MapFolderClaim claim_;
  mutable std::mutex folder_mutex_;  // folder_ for path()
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
