#include "multiview_object_detection/simulation/dataset_files.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <system_error>

namespace mvod {
namespace simulation {

namespace fs = std::filesystem;

std::string formatNumber(double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.9g", std::abs(value) < 1e-12 ? 0.0 : value);
  return buffer;
}

Status writeText(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  if (!out) return Status::Error("cannot write " + path.string());
  out << text;
  out.close();
  if (!out) return Status::Error("cannot write " + path.string());
  return Status::Ok();
}

Status makeFolder(const std::string& directory) {
  std::error_code error;
  fs::create_directories(directory, error);
  if (error || !fs::is_directory(directory)) {
    return Status::Error("cannot create folder " + directory +
                         (error ? ": " + error.message() : std::string()));
  }
  return Status::Ok();
}

Status writeImage(const fs::path& path, const cv::Mat& image) {
  bool written = false;
  try {
    written = cv::imwrite(path.string(), image);
  } catch (const cv::Exception&) {
    written = false;
  }
  return written ? Status::Ok() : Status::Error("cannot write " + path.string());
}

}  // namespace simulation
}  // namespace mvod
