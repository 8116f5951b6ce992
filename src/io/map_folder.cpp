#include "multiview_object_detection/io/map_folder.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <sstream>
#include <thread>

#include "history_json.h"
#include "json_fields.h"
#include "map_document.h"

namespace mvod {
namespace {

using json_fields::fieldError;
using nlohmann::json;

constexpr char kMapFile[] = "map.json";
constexpr char kKeyframeFolder[] = "keyframes";
constexpr char kKeyframeMagic[] = "MVODKF01";  // 8 bytes
constexpr std::size_t kMagicBytes = 8;

bool endsWith(const std::string& text, const std::string& end) {
  return text.size() >= end.size() && text.compare(text.size() - end.size(), end.size(), end) == 0;
}

std::string errnoText() { return std::strerror(errno); }

// A keyframe file's name as the writers make them: "kf" digits, '-', [0-9a-f.-], ".kf".
bool isKeyframeFileName(const std::string& name) {
  if (name.size() < 6 || name.compare(0, 2, "kf") != 0 || !endsWith(name, ".kf")) return false;
  for (const char c : name) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '.')) return false;
  }
  return name.find("..") == std::string::npos;
}

// `path` as lstat sees it; what it is for a message.
struct PathKind {
  bool exists = false;
  bool absent = false;  // lstat said there is nothing at the path (not: it could not look)
  bool directory = false;
  bool regular = false;
  bool link = false;
  double mtime_s = 0.0;
};

PathKind kindOf(const std::string& path) {
  PathKind kind;
  struct stat info {};
  if (::lstat(path.c_str(), &info) != 0) {
    kind.absent = errno == ENOENT;
    return kind;
  }
  kind.exists = true;
  kind.directory = S_ISDIR(info.st_mode);
  kind.regular = S_ISREG(info.st_mode);
  kind.link = S_ISLNK(info.st_mode);
  kind.mtime_s =
      static_cast<double>(info.st_mtim.tv_sec) + 1e-9 * static_cast<double>(info.st_mtim.tv_nsec);
  return kind;
}

// A folder at `path`, made if missing; never through a link.
Status makeFolder(const std::string& path) {
  const PathKind kind = kindOf(path);
  if (kind.link) {
    return Status::Error(path + " is " + describeLink(path) +
                         "; a map is never written through a link");
  }
  if (kind.exists && !kind.directory) {
    return Status::Error(path + " exists and is not a folder (a map folder is written there)");
  }
  if (!kind.exists && ::mkdir(path.c_str(), 0777) != 0 && errno != EEXIST) {
    return Status::Error("cannot create " + path + ": " + errnoText());
  }
  return Status::Ok();
}

// The names in `folder` (empty when it cannot be listed).
std::set<std::string> namesIn(const std::string& folder) {
  std::set<std::string> names;
  DIR* dir = ::opendir(folder.c_str());
  if (dir == nullptr) return names;
  while (const dirent* entry = ::readdir(dir)) names.insert(entry->d_name);
  ::closedir(dir);
  return names;
}

// Writes `bytes` to a new file `path` (it must not exist) and syncs its data.
Status writeNewFile(const std::string& path, const std::string& bytes) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
  if (fd < 0) return Status::Error("cannot create " + path + ": " + errnoText());
  std::size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + written, bytes.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const std::string message = "cannot write " + path + ": " + errnoText();
      ::close(fd);
      ::unlink(path.c_str());
      return Status::Error(message);
    }
    written += static_cast<std::size_t>(n);
  }
  if (::fdatasync(fd) != 0 || ::close(fd) != 0) {
    const std::string message = "cannot write " + path + ": " + errnoText();
    ::unlink(path.c_str());
    return Status::Error(message);
  }
  return Status::Ok();
}

void syncFolder(const std::string& folder) {
  const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

std::string notARegularFile(const std::string& path, unsigned int mode) {
  return path + " is " + fileKindText(mode) +
         ", not a regular file: a map folder's lock file must be one (remove it; the next save "
         "makes it again)";
}

// A flock on <folder>/.lock: exclusive for a writer's whole save, shared for a reader's whole
// load (threads and processes), so that no save removes the files of the map.json a load is
// reading. A reader of a folder without the file (nothing wrote it yet) goes without. Nothing here
// can block for good: the file is opened with O_NONBLOCK (a FIFO put there does not wait for a
// writer) and must be a regular file, and the lock is waited for at most kLockWaitS (a save or
// load of another process that hangs holding it).
constexpr double kLockWaitS = 120.0;

class FolderLock {
 public:
  FolderLock(const std::string& folder, bool exclusive) {
    const std::string path = folder + "/.lock";
    const int flags = O_NONBLOCK | O_NOFOLLOW | O_CLOEXEC;
    fd_ = exclusive ? ::open(path.c_str(), O_RDWR | O_CREAT | flags, 0666)
                    : ::open(path.c_str(), O_RDONLY | flags);
    if (fd_ < 0) {
      if (!exclusive && errno == ENOENT) return;
      const std::string why = errnoText();
      struct stat info {};
      error_ = ::lstat(path.c_str(), &info) == 0 && !S_ISREG(info.st_mode)
                   ? notARegularFile(path, info.st_mode)
                   : "cannot open " + path + ": " + why;
      return;
    }
    struct stat info {};
    if (::fstat(fd_, &info) != 0 || !S_ISREG(info.st_mode)) {
      error_ = notARegularFile(path, info.st_mode);
      ::close(fd_);
      fd_ = -1;
      return;
    }
    const auto deadline =
        std::chrono::steady_clock::now() + std::chrono::duration<double>(kLockWaitS);
    while (::flock(fd_, (exclusive ? LOCK_EX : LOCK_SH) | LOCK_NB) != 0) {
      if (errno == EINTR) continue;
      if (errno != EWOULDBLOCK || std::chrono::steady_clock::now() > deadline) {
        error_ = errno != EWOULDBLOCK
                     ? "cannot lock " + path + ": " + errnoText()
                     : path + " stayed locked for " + std::to_string(static_cast<int>(kLockWaitS)) +
                           " s by another save or load of the folder (a process that hangs?)";
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  ~FolderLock() {
    if (fd_ >= 0) ::close(fd_);  // releases the lock
  }
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;
  const std::string& error() const { return error_; }

 private:
  int fd_ = -1;
  std::string error_;
};

std::string encodeKeyframe(const KeyframeRecord& record) {
  std::string blobs;
  const std::string header = history_json::recordToJson(record, &blobs)
                                 .dump(-1, ' ', false, json::error_handler_t::replace);
  std::string out(kKeyframeMagic, kMagicBytes);
  const std::uint64_t header_bytes = header.size();
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>((header_bytes >> (8 * i)) & 0xff));
  out += header;
  out += blobs;
  return out;
}

Status decodeKeyframe(const std::string& bytes, const std::string& path, KeyframeRecord* record) {
  if (bytes.size() < kMagicBytes + 8 || bytes.compare(0, kMagicBytes, kKeyframeMagic) != 0) {
    return Status::Error(path + ": not a keyframe file (no MVODKF01 header)");
  }
  std::uint64_t header_bytes = 0;
  for (int i = 0; i < 8; ++i) {
    header_bytes |= static_cast<std::uint64_t>(static_cast<unsigned char>(bytes[kMagicBytes + i]))
                    << (8 * i);
  }
  const std::size_t start = kMagicBytes + 8;
  if (header_bytes > bytes.size() - start) {
    return Status::Error(path + ": the header runs past the end of the file (truncated?)");
  }
  json header;
  const Status parsed = map_document::parse(bytes.substr(start, header_bytes), path, &header);
  if (!parsed) return parsed;
  const std::string blobs = bytes.substr(start + header_bytes);
  return history_json::recordFromJson(header, path, &blobs, record);
}

std::string randomSession() {
  std::random_device device;
  std::ostringstream out;
  out << std::hex << device() << device();
  return out.str();
}

// One manifest entry: the keyframe's file, its pose now, the objects of its views and whether the
// refinement ran after it (all change without the keyframe's data changing).
json manifestEntry(const KeyframeRecord& record, const std::string& file) {
  json object_ids = json::array();
  for (const RecordedView& view : record.views) object_ids.push_back(view.object_id);
  json entry{{"file", file},
             {"keyframe", record.keyframe},
             {"T_W_D", history_json::poseToJson(record.T_W_D)},
             {"object_ids", object_ids}};
  if (record.refined_after) entry["refined_after"] = true;
  return entry;
}

Status readManifestEntry(const json& entry, const std::string& folder, const std::string& path,
                         KeyframeRecord* record) {
  if (!entry.is_object()) return fieldError(path, "expected an object");
  const std::string p = path + ".";
  const json* file = nullptr;
  Status status = json_fields::member(entry, p, "file", &file);
  if (!status) return status;
  if (!file->is_string() || !isKeyframeFileName(file->get<std::string>())) {
    return fieldError(p + "file", "expected the name of a keyframe file (kf....kf)");
  }
  const std::string file_path =
      folder + "/" + kKeyframeFolder + "/" + file->get_ref<const std::string&>();
  int keyframe = 0;
  Eigen::Isometry3d T_W_D;
  if (!(status = json_fields::readInt(entry, p, "keyframe", 0, &keyframe)) ||
      !(status = history_json::readPose(entry, p, "T_W_D", &T_W_D))) {
    return status;
  }
  const json* object_ids = nullptr;
  if (!(status = json_fields::member(entry, p, "object_ids", &object_ids))) return status;
  std::string bytes;
  if (!(status = readFile(file_path, &bytes, kMaxKeyframeFileBytes, Links::kRefuse))) {
    return Status::Error(path + ": " + status.message());
  }
  KeyframeRecord read;
  if (!(status = decodeKeyframe(bytes, file_path, &read))) return status;
  if (read.keyframe != keyframe) {
    return fieldError(p + "keyframe",
                      "the file " + file_path + " holds keyframe " + std::to_string(read.keyframe));
  }
  if (!object_ids->is_array() || object_ids->size() != read.views.size()) {
    return fieldError(p + "object_ids", "expected one id per view of the keyframe file");
  }
  for (std::size_t i = 0; i < read.views.size(); ++i) {
    const json& id = (*object_ids)[i];
    // An id that names no object of the map is allowed: the object was refined away after the
    // keyframe. Past kMaxObjectId no object id can be (a corrupt or forged file).
    if (!id.is_number_integer() || id.get<std::int64_t>() < -1 ||
        id.get<std::int64_t>() > kMaxObjectId) {
      return fieldError(p + "object_ids",
                        "expected integers in [-1, " + std::to_string(kMaxObjectId) + "]");
    }
    read.views[i].object_id = id.get<int>();
  }
  const auto refined = entry.find("refined_after");  // absent: false
  if (refined != entry.end() && !refined->is_boolean()) {
    return fieldError(p + "refined_after", "expected true or false");
  }
  read.refined_after = refined != entry.end() && refined->get<bool>();
  read.T_W_D = T_W_D;
  *record = std::move(read);
  return Status::Ok();
}

Status readMapFolder(const std::string& folder, std::vector<MapObject>* objects,
                     MapSummary* summary, std::deque<KeyframeRecord>* history,
                     std::map<int, std::string>* keyframe_files) {
  const std::string map_path = folder + "/" + kMapFile;
  // The keyframes are read from the folder itself: a link there would read (and the next save
  // would refuse to write) files outside it.
  const std::string keyframe_folder = folder + "/" + kKeyframeFolder;
  const PathKind keyframes = kindOf(keyframe_folder);
  if (keyframes.link) {
    return Status::Error(keyframe_folder + " is " + describeLink(keyframe_folder) +
                         "; a map's keyframes are never read or saved through a link (put the "
                         "files themselves in a folder of that name)");
  }
  if (keyframes.exists && !keyframes.directory) {
    return Status::Error(keyframe_folder + " exists and is not a folder");
  }
  const FolderLock lock(folder, false);
  if (!lock.error().empty()) return Status::Error(lock.error());
  std::string text;
  Status status = readFile(map_path, &text, kDefaultMaxFileBytes, Links::kRefuse);
  if (!status) return status;
  json doc;
  if (!(status = map_document::parse(text, map_path, &doc))) return status;
  text.clear();
  std::vector<MapObject> parsed_objects;
  MapSummary parsed_summary;
  std::deque<KeyframeRecord> parsed_history;
  if (!(status = map_document::fromJson(doc, &parsed_objects, &parsed_summary, &parsed_history))) {
    return Status::Error(map_path + ": " + status.message());
  }
  std::map<int, std::string> read_files;
  const auto files = doc.find("keyframe_files");
  if (files != doc.end()) {
    if (!files->is_array()) return fieldError("keyframe_files", "expected an array");
    for (std::size_t i = 0; i < files->size(); ++i) {
      KeyframeRecord record;
      status = readManifestEntry((*files)[i], folder, "keyframe_files[" + std::to_string(i) + "]",
                                 &record);
      if (!status) return Status::Error(map_path + ": " + status.message());
      if (!parsed_history.empty() && !(record.keyframe > parsed_history.back().keyframe)) {
        return Status::Error(map_path + ": keyframe_files[" + std::to_string(i) +
                             "]: keyframes must come in keyframe order");
      }
      read_files[record.keyframe] = (*files)[i].at("file").get<std::string>();
      parsed_history.push_back(std::move(record));
    }
  }
  if (objects != nullptr) *objects = std::move(parsed_objects);
  if (keyframe_files != nullptr) *keyframe_files = std::move(read_files);
  if (summary != nullptr) *summary = parsed_summary;
  if (history != nullptr) *history = std::move(parsed_history);
  return Status::Ok();
}

}  // namespace

std::string mapFolderPath(const std::string& path) {
  if (endsWith(path, kMapFolderExtension)) return path;
  const std::string stem = endsWith(path, ".json") ? path.substr(0, path.size() - 5) : path;
  return stem + kMapFolderExtension;
}

std::string mapToLoad(const std::string& path) {
  const std::string folder = mapFolderPath(path);
  const PathKind folder_kind = kindOf(folder);
  const PathKind map_kind = kindOf(folder + "/" + kMapFile);
  const bool has_folder = folder_kind.directory && map_kind.exists;
  const PathKind file_kind = folder == path ? PathKind() : kindOf(path);
  if (has_folder && (!file_kind.exists || map_kind.mtime_s >= file_kind.mtime_s)) return folder;
  if (file_kind.exists) return path;
  // A folder without map.json holds no map: its first save was killed before map.json (the file
  // that makes a save), or nothing was saved into it. Anything else there (a link, a file, a
  // map.json that cannot be looked at) is returned, for the load to say what is wrong with it.
  const bool no_map_in_folder = folder_kind.directory && map_kind.absent;
  return has_folder || (folder_kind.exists && !no_map_in_folder) ? folder : "";
}

std::string noMapText(const std::string& path) {
  const std::string folder = mapFolderPath(path);
  if (kindOf(folder).directory) {
    return folder + " holds no " + kMapFile +
           " (a first save killed before writing it, or nothing saved there yet)";
  }
  return "no map at " + folder + (folder == path ? "" : " (nor a map file " + path + ")");
}

MapFolderWriter::MapFolderWriter() : session_(randomSession()) {}

Status MapFolderWriter::write(const std::string& folder, const std::vector<MapObject>& objects,
                              const MapSummary& summary, const std::deque<KeyframeRecord>& history,
                              Report* report) {
  Report local;
  Report& out = report != nullptr ? *report : local;
  out = Report();
  if (!endsWith(folder, kMapFolderExtension)) {
    return Status::Error(folder + ": a map folder's name ends in " + kMapFolderExtension);
  }
  const std::string keyframe_folder = folder + "/" + kKeyframeFolder;
  Status status = makeFolder(folder);
  if (status) status = makeFolder(keyframe_folder);
  if (!status) return status;
  const FolderLock lock(folder, true);
  if (!lock.error().empty()) return Status::Error(lock.error());
  if (folder != folder_) written_.clear();
  folder_ = folder;

  const std::set<std::string> present = namesIn(keyframe_folder);
  std::map<std::pair<std::uint64_t, int>, std::string> written;
  std::set<std::string> referenced;
  json manifest = json::array();
  for (const KeyframeRecord& record : history) {
    const auto key = std::make_pair(record.uid, record.revision);
    const auto known = written_.find(key);
    std::string name;
    if (record.uid != 0 && known != written_.end() && present.count(known->second) != 0) {
      name = known->second;
      ++out.keyframe_files_reused;
    } else {
      std::ostringstream file;
      file << "kf" << record.keyframe << "-" << session_ << "-" << record.uid << "."
           << record.revision << "-" << next_file_++ << ".kf";
      name = file.str();
      const std::string bytes = encodeKeyframe(record);
      status = writeNewFile(keyframe_folder + "/" + name, bytes);
      if (!status) return status;
      out.bytes_written += bytes.size();
      ++out.keyframe_files_written;
    }
    struct stat info {};
    if (::lstat((keyframe_folder + "/" + name).c_str(), &info) == 0) {
      out.folder_bytes += static_cast<std::size_t>(info.st_size);
    }
    if (record.uid != 0) written[key] = name;
    referenced.insert(name);
    manifest.push_back(manifestEntry(record, name));
  }
  // The new files' names are durable before map.json names them.
  if (out.keyframe_files_written > 0) syncFolder(keyframe_folder);
  json doc = map_document::toJson(objects, summary, true);
  doc["keyframe_files"] = std::move(manifest);
  const std::string text = map_document::dump(doc, true);
  if (!(status = writeFileAtomic(folder + "/" + kMapFile, text))) return status;
  out.bytes_written += text.size();
  out.folder_bytes += text.size();
  // The map now names only `referenced`: the keyframe files of earlier saves go.
  for (const std::string& name : namesIn(keyframe_folder)) {
    if (referenced.count(name) != 0 || !isKeyframeFileName(name)) continue;
    if (::unlink((keyframe_folder + "/" + name).c_str()) == 0) ++out.keyframe_files_removed;
  }
  written_ = std::move(written);
  return Status::Ok();
}

void MapFolderWriter::adopt(const std::string& folder, const std::deque<KeyframeRecord>& history,
                            const std::map<int, std::string>& loaded_files) {
  if (folder != folder_) written_.clear();
  folder_ = folder;
  for (const KeyframeRecord& record : history) {
    const auto file = loaded_files.find(record.keyframe);
    if (record.uid == 0 || record.revision != 0 || file == loaded_files.end()) continue;
    written_[std::make_pair(record.uid, record.revision)] = file->second;
  }
}

MapFolderClaim::~MapFolderClaim() { release(); }

void MapFolderClaim::release() {
  if (fd_ >= 0) ::close(fd_);  // releases the flock
  fd_ = -1;
}

Status MapFolderClaim::claim(const std::string& folder) {
  release();
  const Status made = makeFolder(folder);
  if (!made) return made;
  const std::string path = folder + "/.owner";
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_NONBLOCK | O_NOFOLLOW | O_CLOEXEC, 0666);
  struct stat info {};
  if (fd < 0 || ::fstat(fd, &info) != 0 || !S_ISREG(info.st_mode)) {
    const std::string why = errnoText();
    if (fd >= 0) ::close(fd);
    return ::lstat(path.c_str(), &info) == 0 && !S_ISREG(info.st_mode)
               ? Status::Error(path + " is " + fileKindText(info.st_mode) +
                               ", not a regular file (remove it)")
               : Status::Error("cannot open " + path + ": " + why);
  }
  while (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    if (errno == EINTR) continue;
    const bool taken = errno == EWOULDBLOCK;
    const std::string why = errnoText();
    std::string holder;
    char buffer[32] = {};
    const ssize_t n = ::pread(fd, buffer, sizeof(buffer) - 1, 0);
    if (n > 0) holder = std::string(buffer, static_cast<std::size_t>(n));
    while (!holder.empty() && std::isspace(static_cast<unsigned char>(holder.back()))) {
      holder.pop_back();
    }
    ::close(fd);
    if (!taken) return Status::Error("cannot lock " + path + ": " + why);
    return Status::Error(folder + " is in use by another process" +
                         (holder.empty() ? std::string() : " (pid " + holder + ")") +
                         ": two nodes saving to one folder would overwrite each other's maps");
  }
  const std::string pid = std::to_string(::getpid()) + "\n";
  if (::ftruncate(fd, 0) != 0 || ::pwrite(fd, pid.data(), pid.size(), 0) < 0) {
    // The claim holds without the pid; only the message of a refused claim lacks it.
  }
  fd_ = fd;
  return Status::Ok();
}

Status loadMap(const std::string& path, Links links, std::vector<MapObject>* objects,
               MapSummary* summary, std::deque<KeyframeRecord>* history,
               std::map<int, std::string>* keyframe_files) {
  const PathKind kind = kindOf(path);
  if (kind.link && links == Links::kRefuse) {
    return Status::Error(path + " is " + describeLink(path) +
                         "; maps are read by their own path, never through a link");
  }
  if (kind.directory || (kind.link && std::filesystem::is_directory(path))) {
    return readMapFolder(path, objects, summary, history, keyframe_files);
  }
  std::string text;
  Status status = readFile(path, &text, kMaxSingleFileMapBytes, links);
  if (status) status = objectsFromJson(text, objects, summary, history);
  if (status && keyframe_files != nullptr) keyframe_files->clear();
  return status;
}

}  // namespace mvod
