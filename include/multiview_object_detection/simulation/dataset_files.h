// Writing the files of the synthetic datasets: numbers as text, folders, text files and images.
// Errors name the path.
#pragma once

#include <filesystem>
#include <opencv2/core.hpp>
#include <string>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {
namespace simulation {

// "%.9g"; |value| < 1e-12 (and -0) is written as 0.
std::string formatNumber(double value);
Status writeText(const std::filesystem::path& path, const std::string& text);
// The folder and its parents.
Status makeFolder(const std::string& directory);
// cv::imwrite (the format by the extension); an OpenCV exception is an error too.
Status writeImage(const std::filesystem::path& path, const cv::Mat& image);

}  // namespace simulation
}  // namespace mvod
