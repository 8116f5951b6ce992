#include "multiview_object_detection/io/map_path.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "multiview_object_detection/io/file_io.h"

namespace mvod {
namespace fs = std::filesystem;

std::string defaultMapDirectory() {
  const char* ros_home = std::getenv("ROS_HOME");
  if (ros_home != nullptr && ros_home[0] == '/') {
    return std::string(ros_home) + "/multiview_object_detection/maps";
  }
  const char* home = std::getenv("HOME");
  if (home != nullptr && home[0] == '/') {
    return std::string(home) + "/.ros/multiview_object_detection/maps";
  }
  return "/tmp/multiview_object_detection/maps";
}

namespace {

// `child` is `parent` or below it (both normal, absolute).
bool liesIn(const fs::path& child, const fs::path& parent) {
  auto c = child.begin();
  for (auto p = parent.begin(); p != parent.end(); ++p, ++c) {
    if (p->empty()) continue;  // a trailing separator
    if (c == child.end() || *c != *p) return false;
  }
  return true;
}

}  // namespace

Status resolveMapPath(const std::string& path, const MapPathPolicy& policy, bool for_writing,
                      std::string* resolved) {
  if (path.empty()) return Status::Error("the path is empty");
  if (path.back() == '/') return Status::Error("'" + path + "' names a directory, not a file");
  const std::string directory = policy.directory.empty() ? defaultMapDirectory() : policy.directory;
  if (directory.empty() || directory[0] != '/') {
    return Status::Error("map_directory '" + directory + "' is not an absolute path");
  }
  std::error_code error;
  const fs::path dir = fs::weakly_canonical(fs::path(directory), error);
  if (error) {
    return Status::Error("map_directory '" + directory + "': " + error.message());
  }
  const fs::path requested = fs::path(path).is_absolute() ? fs::path(path) : dir / path;
  const fs::path name = requested.filename();
  if (name.empty() || name == "." || name == "..") {
    return Status::Error("'" + path + "' names a directory, not a file");
  }
  // The folders' links and '..' resolved (what the open would reach), the file's own name kept: a
  // link there is refused below, never followed to a file the node does not own.
  const fs::path target = fs::weakly_canonical(requested.parent_path(), error) / name;
  if (error) return Status::Error("'" + path + "': " + error.message());
  const bool inside = liesIn(target, dir) && target != dir;
  if (!inside && !policy.allow_any_path) {
    return Status::Error("'" + path + "' (" + target.string() + ") is outside map_directory " +
                         dir.string() +
                         ": give a path relative to it, or set allow_any_map_path to allow "
                         "any path");
  }
  if (for_writing && inside) {
    fs::create_directories(target.parent_path(), error);
    if (error) {
      return Status::Error("cannot create " + target.parent_path().string() + ": " +
                           error.message());
    }
  }
  const std::string link = describeLink(target.string());
  if (!link.empty()) {
    return Status::Error("'" + path + "' (" + target.string() + ") is " + link +
                         ": the node reads, writes and moves aside only map files themselves, "
                         "never through a link; give the file's own path");
  }
  *resolved = target.string();
  return Status::Ok();
}

Status prepareMapDirectory(const MapPathPolicy& policy) {
  const std::string directory = policy.directory.empty() ? defaultMapDirectory() : policy.directory;
  if (directory.empty() || directory[0] != '/') {
    return Status::Error("map_directory '" + directory + "' is not an absolute path");
  }
  std::error_code error;
  fs::create_directories(directory, error);
  if (error) {
    return Status::Error("map_directory '" + directory + "' cannot be created: " + error.message());
  }
  if (!fs::is_directory(directory, error)) {
    return Status::Error("map_directory '" + directory + "' is not a directory");
  }
  // The saves' own temporary names (json_io) start with '.'; this probe's too.
  std::string probe = directory + "/.write-probe-XXXXXX";
  const int fd = ::mkstemp(probe.data());
  if (fd < 0) {
    return Status::Error("map_directory '" + directory +
                         "' is not writable: " + std::strerror(errno));
  }
  ::close(fd);
  ::unlink(probe.c_str());
  return Status::Ok();
}

}  // namespace mvod
