// Helpers both dataset readers (7-Scenes layout, SceneNN) use on their folders. Internal to the
// datasets layer (not installed).
#pragma once

#include <cstddef>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <system_error>

#include "multiview_object_detection/io/file_io.h"
#include "multiview_object_detection/pipeline/types/rgbd_frame.h"

namespace mvod {
namespace dataset_files {

// Frames whose headers are read at open() to learn the cameras' image sizes.
constexpr size_t kSizeProbeFrames = 10;
// Missing files listed by name in a warning; the rest are counted.
constexpr size_t kMaxNamedFrames = 5;

// Size limits of the text files a dataset holds. A pose, intrinsics, gravity or depth-to-colour
// file is a few hundred bytes; a trajectory or time stamp list about 300 bytes a frame (256 MiB:
// 800,000 frames, eight hours at 30 Hz).
constexpr size_t kMaxNumberFileBytes = size_t{1} << 20;
constexpr size_t kMaxListFileBytes = size_t{256} << 20;

// The whole text file at `path` (readFile: a regular file of at most max_bytes; a FIFO, a device, a
// folder or a larger file is refused at once). A missing file is "<path>: no such file".
inline Status readTextFile(const std::string& path, size_t max_bytes, std::string* text) {
  std::error_code error;
  if (!std::filesystem::exists(std::filesystem::symlink_status(path, error))) {
    return Status::Error(path + ": no such file");
  }
  return readFile(path, text, max_bytes);
}

inline bool isFile(const std::filesystem::path& path) {
  std::error_code error;
  return std::filesystem::is_regular_file(path, error);  // follows symbolic links
}

// "640x480" of an image (rgbd_frame.h's sizeText).
inline std::string sizeText(const cv::Mat& m) { return mvod::sizeText(m.cols, m.rows); }

}  // namespace dataset_files
}  // namespace mvod
