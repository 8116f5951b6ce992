#include "multiview_object_detection/datasets/scenenn_dataset.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <sstream>

#include "dataset_file_checks.h"
#include "multiview_object_detection/datasets/dataset_source.h"
#include "multiview_object_detection/io/image_io.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;
using dataset_files::isFile;
using dataset_files::kMaxNamedFrames;
using dataset_files::kSizeProbeFrames;
using dataset_files::sizeText;

bool parseFiniteDouble(const std::string& token, double* value) {
  char* end = nullptr;
  const double v = std::strtod(token.c_str(), &end);
  if (token.empty() || end == token.c_str() || *end != '\0' || !std::isfinite(v)) return false;
  *value = v;
  return true;
}

bool parseInt(const std::string& token, long* value) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(token.c_str(), &end, 10);
  if (token.empty() || *end != '\0' || errno != 0) return false;
  *value = v;
  return true;
}

std::string trim(const std::string& text) {
  const size_t begin = text.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return "";
  const size_t end = text.find_last_not_of(" \t\r\n");
  return text.substr(begin, end - begin + 1);
}

// Printed decimals give a nearly orthonormal rotation: accept small errors and snap to the
// nearest rotation (SVD), as SevenScenesDataset::readPose does.
bool toRigid(const Eigen::Matrix4d& M, Eigen::Isometry3d* T_out) {
  if ((M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-3) return false;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = M.topLeftCorner<3, 3>();
  T.translation() = M.topRightCorner<3, 1>();
  if (!isValidPose(T, 1e-2)) return false;
  T.linear() = nearestRotation(T.linear());
  *T_out = T;
  return true;
}

// "depth00012.png" -> 12 when the name is exactly "depth%05d.png".
bool parseSceneNNDepthFileName(const std::string& file_name, int* index) {
  static const std::string kPrefix = "depth";
  static const std::string kSuffix = ".png";
  if (file_name.size() != kPrefix.size() + 5 + kSuffix.size()) return false;
  if (file_name.compare(0, kPrefix.size(), kPrefix) != 0) return false;
  if (file_name.compare(file_name.size() - kSuffix.size(), kSuffix.size(), kSuffix) != 0) {
    return false;
  }
  const std::string digits = file_name.substr(kPrefix.size(), 5);
  if (!std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    return false;
  }
  *index = std::stoi(digits);
  return true;
}

std::string fileNumber(int index) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%05d", index);
  return buffer;
}

// Colour images image/imageNNNNN.png without depth/depthNNNNN.png are not frames (a frame is its
// depth image): say so, naming the missing files, instead of dropping them silently.
std::vector<std::string> missingSceneNNDepthWarnings(const fs::path& dir,
                                                     const std::vector<int>& frame_indices) {
  const std::set<int> listed(frame_indices.begin(), frame_indices.end());
  std::set<int> without_depth;
  std::error_code error;
  for (fs::directory_iterator it(dir / "image", error), end; !error && it != end;
       it.increment(error)) {
    const std::string file_name = it->path().filename().string();
    int index = 0;
    // "image00012.png" has the shape of "depth00012.png".
    if (file_name.compare(0, 5, "image") == 0 &&
        parseSceneNNDepthFileName("depth" + file_name.substr(5), &index) && !listed.count(index)) {
      without_depth.insert(index);
    }
  }
  if (without_depth.empty()) return {};
  const std::string names =
      nameFirstFrames(std::vector<int>(without_depth.begin(), without_depth.end()), kMaxNamedFrames,
                      [](int index) { return "depth/depth" + fileNumber(index) + ".png"; });
  return {dir.string() + ": " + std::to_string(without_depth.size()) +
          " colour image(s) have no depth image and are skipped: missing " + names};
}

}  // namespace

std::string SceneNNDataset::frameName(int index) { return "image" + fileNumber(index); }

Status SceneNNDataset::readIntrinsics(const std::string& path, CameraIntrinsics* K) {
  std::string text;
  const Status read = dataset_files::readTextFile(path, dataset_files::kMaxNumberFileBytes, &text);
  if (!read) return read;
  std::istringstream in(text);
  CameraIntrinsics result;
  result.fx = kDefaultFocalPx;
  result.fy = kDefaultFocalPx;
  result.cx = kDefaultCx;
  result.cy = kDefaultCy;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const size_t comment = line.find_first_of("#;");
    if (comment != std::string::npos) line.erase(comment);
    line = trim(line);
    if (line.empty() || line.front() == '[') continue;
    // "key value", "key = value" or "key=value".
    std::replace(line.begin(), line.end(), '=', ' ');
    std::istringstream fields(line);
    std::string key, value_text, extra;
    fields >> key >> value_text;
    double* target = nullptr;
    if (key == "fx") target = &result.fx;
    if (key == "fy") target = &result.fy;
    if (key == "cx") target = &result.cx;
    if (key == "cy") target = &result.cy;
    if (target == nullptr) continue;  // depth_width, baseline ... are not needed
    double value = 0.0;
    if (!parseFiniteDouble(value_text, &value) || (fields >> extra)) {
      return Status::Error(path + ":" + std::to_string(line_number) + ": '" + key +
                           "' needs one finite number");
    }
    *target = value;
  }
  if (!(result.fx > 0.0 && result.fy > 0.0)) {
    return Status::Error(path + ": fx and fy must be > 0");
  }
  *K = result;
  return Status::Ok();
}

Status SceneNNDataset::readTrajectory(const std::string& path,
                                      std::map<int, Eigen::Isometry3d>* T_W_C_by_index) {
  std::string text;
  const Status read = dataset_files::readTextFile(path, dataset_files::kMaxListFileBytes, &text);
  if (!read) return read;
  std::istringstream in(text);
  std::map<int, Eigen::Isometry3d> result;
  std::string line;
  int line_number = 0;
  // Skips blank lines; returns false at the end of the file.
  auto nextLine = [&](std::string* out) {
    while (std::getline(in, line)) {
      ++line_number;
      if (!trim(line).empty()) {
        *out = line;
        return true;
      }
    }
    return false;
  };
  std::string header;
  while (nextLine(&header)) {
    const int header_line = line_number;
    std::istringstream header_fields(header);
    std::string index_text;
    header_fields >> index_text;
    long index = 0;
    if (!parseInt(index_text, &index) || index < 0 || index > std::numeric_limits<int>::max()) {
      return Status::Error(path + ":" + std::to_string(header_line) +
                           ": block header must start with a frame index >= 0, got '" + index_text +
                           "'");
    }
    Eigen::Matrix4d M;
    for (int r = 0; r < 4; ++r) {
      std::string row;
      if (!nextLine(&row)) {
        return Status::Error(path + ": block of frame " + std::to_string(index) + " (line " +
                             std::to_string(header_line) + ") ends after " + std::to_string(r) +
                             " of 4 matrix rows");
      }
      std::istringstream row_fields(row);
      std::string token;
      int c = 0;
      while (row_fields >> token) {
        double value = 0.0;
        if (c >= 4 || !parseFiniteDouble(token, &value)) {
          c = -1;
          break;
        }
        M(r, c++) = value;
      }
      if (c != 4) {
        return Status::Error(path + ":" + std::to_string(line_number) +
                             ": a matrix row needs 4 finite numbers");
      }
    }
    Eigen::Isometry3d T;
    if (!toRigid(M, &T)) {
      return Status::Error(path + ": the matrix of frame " + std::to_string(index) + " (line " +
                           std::to_string(header_line) +
                           ") is not a rigid transform (last row 0 0 0 1, orthonormal rotation)");
    }
    if (!result.emplace(static_cast<int>(index), T).second) {
      return Status::Error(path + ":" + std::to_string(header_line) + ": frame " +
                           std::to_string(index) + " appears twice");
    }
  }
  if (result.empty()) return Status::Error(path + ": no poses");
  *T_W_C_by_index = std::move(result);
  return Status::Ok();
}

Status SceneNNDataset::readTimestamps(const std::string& path,
                                      std::map<int, double>* stamp_s_by_frame) {
  std::string text;
  const Status read = dataset_files::readTextFile(path, dataset_files::kMaxListFileBytes, &text);
  if (!read) return read;
  std::istringstream in(text);
  std::map<int, double> result;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (trim(line).empty()) continue;
    std::istringstream fields(line);
    std::string frame_text, color_text, depth_text, extra;
    fields >> frame_text >> color_text >> depth_text;
    long frame = 0;
    double color_us = 0.0, depth_us = 0.0;
    if (!parseInt(frame_text, &frame) || frame < 0 || frame > std::numeric_limits<int>::max() ||
        !parseFiniteDouble(color_text, &color_us) || !parseFiniteDouble(depth_text, &depth_us) ||
        (fields >> extra)) {
      return Status::Error(path + ":" + std::to_string(line_number) +
                           ": expected 'frame color_us depth_us', got '" + trim(line) + "'");
    }
    if (color_us < 0.0) {
      return Status::Error(path + ":" + std::to_string(line_number) + ": negative time stamp");
    }
    if (!result.emplace(static_cast<int>(frame), color_us * 1e-6).second) {
      return Status::Error(path + ":" + std::to_string(line_number) + ": frame " +
                           std::to_string(frame) + " appears twice");
    }
  }
  if (result.empty()) return Status::Error(path + ": no time stamps");
  *stamp_s_by_frame = std::move(result);
  return Status::Ok();
}

Status SceneNNDataset::open(const std::string& directory, SceneNNDataset* dataset) {
  if (dataset == nullptr) return Status::Error("open: dataset is null");
  std::error_code error;
  if (!fs::exists(directory, error)) {
    return Status::Error(directory + ": dataset folder does not exist");
  }
  if (!fs::is_directory(directory, error)) return Status::Error(directory + ": not a folder");

  SceneNNDataset result;
  result.directory_ = directory;
  const fs::path dir(directory);

  // Intrinsics: the sequence's own asus.ini, else the main repo's shared intrinsic/asus.ini.
  result.K_.fx = kDefaultFocalPx;
  result.K_.fy = kDefaultFocalPx;
  result.K_.cx = kDefaultCx;
  result.K_.cy = kDefaultCy;
  for (const fs::path& candidate :
       {dir / "asus.ini", dir / "intrinsic" / "asus.ini", dir / ".." / "intrinsic" / "asus.ini"}) {
    if (!fs::exists(candidate, error)) continue;
    const Status status = readIntrinsics(candidate.string(), &result.K_);
    if (!status) return status;
    result.intrinsics_path_ = candidate.string();
    break;
  }

  const fs::path depth_dir = dir / "depth";
  if (!fs::is_directory(depth_dir, error)) {
    return Status::Error(depth_dir.string() + ": no such folder (expected depth/depthNNNNN.png)");
  }
  for (fs::directory_iterator it(depth_dir, error), end; !error && it != end; it.increment(error)) {
    int index = 0;
    if (parseSceneNNDepthFileName(it->path().filename().string(), &index)) {
      result.frame_indices_.push_back(index);
    }
  }
  if (error) return Status::Error(depth_dir.string() + ": cannot list: " + error.message());
  if (result.frame_indices_.empty()) {
    return Status::Error(depth_dir.string() + ": no depthNNNNN.png files");
  }
  std::sort(result.frame_indices_.begin(), result.frame_indices_.end());
  result.warnings_ = missingSceneNNDepthWarnings(dir, result.frame_indices_);
  // The camera's image size from the first readable depth header (no decoding).
  for (size_t k = 0; k < result.frame_indices_.size() && k < kSizeProbeFrames; ++k) {
    const fs::path depth_path =
        depth_dir / ("depth" + fileNumber(result.frame_indices_[k]) + ".png");
    ImageHeader header;
    if (readImageFileHeader(depth_path.string(), &header) &&
        int64_t{header.size.width} * header.size.height <= kDefaultMaxImagePixels) {
      result.image_size_ = header.size;
      result.image_size_source_ = "depth/" + depth_path.filename().string();
      break;
    }
  }

  const std::string trajectory_path = (dir / "trajectory.log").string();
  Status status = readTrajectory(trajectory_path, &result.T_W_C_by_index_);
  if (!status) return status;

  const fs::path timestamp_path = dir / "timestamp.txt";
  if (fs::exists(timestamp_path, error)) {
    status = readTimestamps(timestamp_path.string(), &result.stamps_s_);
    if (!status) return status;
  }

  *dataset = std::move(result);
  return Status::Ok();
}

Status SceneNNDataset::checkFrame(int index) const {
  const fs::path dir(directory_);
  if (index < 1 || T_W_C_by_index_.count(index - 1) == 0) {
    return Status::Error((dir / "trajectory.log").string() + ": no pose for frame " +
                         std::to_string(index) + " (depth/depth" + fileNumber(index) +
                         ".png; expected a block with header index " + std::to_string(index - 1) +
                         ")");
  }
  if (hasTimestamps() && stamps_s_.count(index) == 0) {
    return Status::Error((dir / "timestamp.txt").string() + ": no time stamp for frame " +
                         std::to_string(index));
  }
  return Status::Ok();
}

double SceneNNDataset::stampOf(int index) const {
  if (!hasTimestamps()) return (index - 1) / kDefaultFrameRateHz;
  const auto found = stamps_s_.find(index);
  return found != stamps_s_.end() ? found->second : std::numeric_limits<double>::quiet_NaN();
}

Status SceneNNDataset::load(int index, RgbdFrame* frame) const {
  if (frame == nullptr) return Status::Error("load: frame is null");
  const fs::path dir(directory_);
  const fs::path color_path = dir / "image" / ("image" + fileNumber(index) + ".png");
  const fs::path depth_path = dir / "depth" / ("depth" + fileNumber(index) + ".png");
  if (!isFile(color_path)) return Status::Error(color_path.string() + ": no such file");
  if (!isFile(depth_path)) return Status::Error(depth_path.string() + ": no such file");
  const Status check = checkFrame(index);
  if (!check) return check;

  RgbdFrame result;
  result.index = index;
  result.name = frameName(index);
  result.stamp_s = hasTimestamps() ? stamps_s_.at(index) : (index - 1) / kDefaultFrameRateHz;
  result.T_W_D = T_W_C_by_index_.at(index - 1);

  // Sizes are checked from the headers before anything is decoded (image bombs).
  Status status = readImageChecked(depth_path.string(), cv::IMREAD_UNCHANGED, image_size_,
                                   kDefaultMaxImagePixels, &result.depth,
                                   "the camera's size, from " + image_size_source_);
  if (!status) return status;
  if (result.depth.type() != CV_16UC1) {
    return Status::Error(depth_path.string() +
                         ": expected a 16-bit single-channel depth image (millimetres)");
  }
  status = readImageChecked(color_path.string(), cv::IMREAD_COLOR, result.depth.size(),
                            kDefaultMaxImagePixels, &result.color_bgr,
                            "the depth image's size: SceneNN depth is registered to colour");
  if (!status) return status;
  if (result.color_bgr.size() != result.depth.size()) {
    return Status::Error(depth_path.string() + ": depth " + sizeText(result.depth) +
                         " but colour " + sizeText(result.color_bgr) +
                         "; SceneNN depth is registered to colour and must be the same size");
  }
  result.K_depth = K_;
  result.K_depth.width = result.depth.cols;
  result.K_depth.height = result.depth.rows;
  result.K_color = result.K_depth;
  result.registered = true;
  result.T_C_D = Eigen::Isometry3d::Identity();

  status = result.validate();
  if (!status) return status;
  *frame = std::move(result);
  return Status::Ok();
}

Status registerDepthToColor(const cv::Mat& depth_D, const CameraIntrinsics& K_depth,
                            const CameraIntrinsics& K_color, const Eigen::Isometry3d& T_C_D,
                            cv::Mat* depth_C_mm) {
  if (depth_C_mm == nullptr) return Status::Error("registerDepthToColor: output is null");
  if (depth_D.empty() || (depth_D.type() != CV_16UC1 && depth_D.type() != CV_32FC1)) {
    return Status::Error("registerDepthToColor: depth must be a non-empty 16UC1 or 32FC1 image");
  }
  if (!K_depth.isValid() || !K_color.isValid() || K_color.width <= 0 || K_color.height <= 0) {
    return Status::Error(
        "registerDepthToColor: invalid intrinsics (the colour camera needs its image size)");
  }
  if (!isValidPose(T_C_D, 1e-3)) {
    return Status::Error("registerDepthToColor: T_C_D is not a rigid transform");
  }
  const bool millimetres = depth_D.type() == CV_16UC1;
  // Z-buffer in metres; the nearest surface wins where several depth pixels land on one pixel.
  cv::Mat z_C(K_color.height, K_color.width, CV_32FC1,
              cv::Scalar(std::numeric_limits<float>::infinity()));
  const Eigen::Matrix3d R = T_C_D.linear();
  const Eigen::Vector3d t = T_C_D.translation();
  for (int v = 0; v < depth_D.rows; ++v) {
    for (int u = 0; u < depth_D.cols; ++u) {
      double z = 0.0;
      if (millimetres) {
        const uint16_t mm = depth_D.at<uint16_t>(v, u);
        if (mm == 65535) continue;  // saturated / invalid on Kinect-style sensors (7-Scenes)
        z = mm * 1e-3;
      } else {
        z = depth_D.at<float>(v, u);
      }
      if (!(z > 0.0) || !std::isfinite(z)) continue;
      const Eigen::Vector3d p_D((u - K_depth.cx) * z / K_depth.fx,
                                (v - K_depth.cy) * z / K_depth.fy, z);
      const Eigen::Vector3d p_C = R * p_D + t;
      if (!(p_C.z() > 1e-6)) continue;
      const double u_C = K_color.fx * p_C.x() / p_C.z() + K_color.cx;
      const double v_C = K_color.fy * p_C.y() / p_C.z() + K_color.cy;
      const long col = std::lround(u_C);
      const long row = std::lround(v_C);
      if (col < 0 || row < 0 || col >= K_color.width || row >= K_color.height) continue;
      float& best = z_C.at<float>(static_cast<int>(row), static_cast<int>(col));
      best = std::min(best, static_cast<float>(p_C.z()));
    }
  }
  cv::Mat out(K_color.height, K_color.width, CV_16UC1, cv::Scalar(0));
  for (int v = 0; v < out.rows; ++v) {
    for (int u = 0; u < out.cols; ++u) {
      const float z = z_C.at<float>(v, u);
      if (std::isfinite(z)) {
        out.at<uint16_t>(v, u) =
            static_cast<uint16_t>(std::min(65534.0, std::round(static_cast<double>(z) * 1e3)));
      }
    }
  }
  *depth_C_mm = out;
  return Status::Ok();
}

}  // namespace mvod
