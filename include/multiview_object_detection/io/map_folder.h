// The node's map on disk: a folder <name>.mvmap that holds the objects in one small file and the
// keyframe history beside it, one file per keyframe, so that a save writes only the keyframes that
// are new or changed since the last one and no file grows with the length of the run:
//
//   <name>.mvmap/map.json                      the objects (with clouds and evidence) and the
//                                              summary, as objects.json, and "keyframe_files":
//                                              per keyframe its file, pose now and object ids
//   <name>.mvmap/keyframes/kf<N>-<id>.kf       a keyframe's data, never changed once written:
//                                              "MVODKF01", the header's size (8 bytes, little-
//                                              endian), the header (JSON: the record as the single-
//                                              file map has it, its arrays as [offset, size]),
//                                              then the arrays (depth PNG or float32, cut points
//                                              and normals float32, voxel keys int64)
//
// map.json is written last and atomically: the folder always holds a whole map, the old or the
// new, whenever a save is killed. Keyframe files of other saves are removed only after map.json no
// longer names them. Saves to one folder, by threads or processes, take turns, and a load waits
// for a save in progress (flock on <name>.mvmap/.lock: exclusive to save, shared to load). Nothing
// is written or read through a symbolic link.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "multiview_object_detection/io/json_io.h"

namespace mvod {

constexpr char kMapFolderExtension[] = ".mvmap";
// A keyframe file larger than this is refused on reading (a 4096 x 4096 depth image is 64 MiB as
// float32; a keyframe is bounded by corrections/max_memory_mb as a whole).
constexpr std::size_t kMaxKeyframeFileBytes = std::size_t{1} << 30;
// A single-file map of 0.9.x: its history is base64 inside the JSON, and the node wrote files past
// 1 GiB. Reading one needs about three times its size in memory, once.
constexpr std::size_t kMaxSingleFileMapBytes = std::size_t{4} << 30;

// Where a map asked for as `path` is saved: `path` itself when it ends in .mvmap, else `path` with
// a trailing ".json" replaced by (or, without one, followed by) ".mvmap".
std::string mapFolderPath(const std::string& path);

// Which map `path` names for loading: the folder mapFolderPath(path), or a single file at `path`
// (the format of 0.9.x and before); where both exist, the one written last. Empty when neither
// exists, and when the folder holds no map.json (a first save killed before writing it).
std::string mapToLoad(const std::string& path);

// Why mapToLoad(path) is empty, for a message: "no map at <folder> (nor a map file <path>)", or
// that the folder holds no map.json.
std::string noMapText(const std::string& path);

// Writes maps to folders. Keeps which keyframe files it wrote, so that saving the same history
// again (the autosave) writes only the records that are new or changed (a new record, a depth
// coarsened or given up); the rest of the folder's files are reused while they exist. One writer
// per saving thread.
class MapFolderWriter {
 public:
  MapFolderWriter();
  struct Report {
    std::size_t bytes_written = 0;  // map.json and the new keyframe files
    std::size_t folder_bytes = 0;   // the whole map as saved
    int keyframe_files_written = 0;
    int keyframe_files_reused = 0;
    int keyframe_files_removed = 0;  // of earlier saves, no longer part of the map
  };
  // `folder`: resolved and absolute (resolveMapPath), ending in .mvmap. `report` may be null.
  Status write(const std::string& folder, const std::vector<MapObject>& objects,
               const MapSummary& summary, const std::deque<KeyframeRecord>& history,
               Report* report = nullptr);
  // Takes the keyframe files of a map loaded from `folder` as written by this writer, so that its
  // next write() there reuses them instead of writing the loaded history again (a node resuming its
  // autosave after a crash). `history`: the records as the map holds them after the load (their
  // uids); `loaded_files`: keyframe number -> file, from loadMap. A record changed since the load
  // (revision > 0) or not named there is not adopted; write() still checks each file is there.
  void adopt(const std::string& folder, const std::deque<KeyframeRecord>& history,
             const std::map<int, std::string>& loaded_files);

 private:
  std::string session_;  // in the names of this writer's files: never another save's name
  std::string folder_;   // the folder written_ refers to
  // (record uid, revision) -> the keyframe file written for it.
  std::map<std::pair<std::uint64_t, int>, std::string> written_;
  std::uint64_t next_file_ = 0;  // in every new file's name: unique within the session
};

// A process's claim on a map folder for as long as it holds this object (a node's autosave folder):
// an exclusive flock on <folder>/.owner, taken without waiting, with the holder's pid in the file.
// While one process holds it, no other can claim the folder (a second node with the same
// autosave_path); the kernel drops it when the process ends, SIGKILL included. Saves and loads do
// not need it (they take turns on .lock).
class MapFolderClaim {
 public:
  MapFolderClaim() = default;
  ~MapFolderClaim();
  MapFolderClaim(const MapFolderClaim&) = delete;
  MapFolderClaim& operator=(const MapFolderClaim&) = delete;
  // Makes `folder` if missing (never through a link) and claims it, releasing any earlier claim.
  // An error says why not: another process holds it (its pid), or the folder cannot be used.
  Status claim(const std::string& folder);
  void release();
  bool held() const { return fd_ >= 0; }

 private:
  int fd_ = -1;
};

// Reads the map at `path`, a map folder or a single-file map (objectsFromJson), whichever it is.
// Every file is read within its limit; the files inside a folder never through a symbolic link,
// `path` itself not either with Links::kRefuse (the node's maps). A malformed map is an error
// naming the file and field, and leaves the outputs untouched. The outputs may be null;
// `keyframe_files`: for a map folder, keyframe number -> the file it was read from (for
// MapFolderWriter::adopt), empty for a single file.
Status loadMap(const std::string& path, Links links, std::vector<MapObject>* objects,
               MapSummary* summary, std::deque<KeyframeRecord>* history,
               std::map<int, std::string>* keyframe_files = nullptr);

}  // namespace mvod
