// Helpers both dataset readers (7-Scenes layout, SceneNN) use on their folders. Internal to the
// datasets layer (not installed).
#pragma once

#include <cstddef>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <system_error>

#include "multiview_object_detection/pipeline/types/rgbd_frame.h"

namespace mvod {
namespace dataset_files {

// Frames whose headers are read at open() to learn the cameras' image sizes.
constexpr size_t kSizeProbeFrames = 10;
// Missing files listed by name in a warning; the rest are counted.
constexpr size_t kMaxNamedFrames = 5;

inline bool isFile(const std::filesystem::path& path) {
  std::error_code error;
  return std::filesystem::is_regular_file(path, error);  // follows symbolic links
}

// "640x480" of an image (rgbd_frame.h's sizeText).
inline std::string sizeText(const cv::Mat& m) { return mvod::sizeText(m.cols, m.rows); }

}  // namespace dataset_files
}  // namespace mvod
