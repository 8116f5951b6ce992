#include "multiview_object_detection/datasets/dataset.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
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

constexpr double kFrameRateHz = 30.0;  // 7-Scenes (Kinect v1)
constexpr double kMaxGravityComponent = 1e6;

// Reads exactly `count` whitespace-separated finite numbers; anything else is an error naming the
// file.
Status readNumbers(const std::string& path, size_t count, std::vector<double>* values) {
  std::string text;
  const Status read = dataset_files::readTextFile(path, dataset_files::kMaxNumberFileBytes, &text);
  if (!read) return read;
  std::istringstream in(text);
  values->clear();
  std::string token;
  while (in >> token) {
    // strtod also takes "nan" and "inf"; they are caught below.
    char* end = nullptr;
    const double value = std::strtod(token.c_str(), &end);
    if (end == token.c_str() || *end != '\0') {
      return Status::Error(path + ": '" + token + "' is not a number");
    }
    if (!std::isfinite(value)) {
      return Status::Error(path + ": non-finite value '" + token + "'");
    }
    values->push_back(value);
    if (values->size() > count) break;
  }
  if (values->size() != count) {
    return Status::Error(path + ": expected " + std::to_string(count) + " numbers, found " +
                         (values->size() > count ? "more" : std::to_string(values->size())));
  }
  return Status::Ok();
}

// A 3x3 pinhole matrix [fx 0 cx; 0 fy cy; 0 0 1] -> intrinsics (size unknown until an image is
// read).
Status intrinsicsFromMatrix(const std::string& path, const Eigen::Matrix3d& K,
                            CameraIntrinsics* intrinsics) {
  if (!(K(0, 0) > 0.0 && K(1, 1) > 0.0)) {
    return Status::Error(path + ": fx and fy must be > 0");
  }
  if (std::abs(K(2, 0)) > 1e-9 || std::abs(K(2, 1)) > 1e-9 || std::abs(K(2, 2) - 1.0) > 1e-9 ||
      std::abs(K(1, 0)) > 1e-9) {
    return Status::Error(path +
                         ": not a pinhole camera matrix (expected rows 'fx 0 cx', '0 fy cy', "
                         "'0 0 1')");
  }
  if (std::abs(K(0, 1)) > 1e-6 * K(0, 0)) {
    return Status::Error(path + ": skewed camera matrices are not supported");
  }
  *intrinsics = CameraIntrinsics();
  intrinsics->fx = K(0, 0);
  intrinsics->fy = K(1, 1);
  intrinsics->cx = K(0, 2);
  intrinsics->cy = K(1, 2);
  return Status::Ok();
}

// "frame-000010.depth.png" -> 10, when the name is exactly what frameName() would give.
bool parseDepthFileName(const std::string& file_name, int* index) {
  static const std::string kPrefix = "frame-";
  static const std::string kSuffix = ".depth.png";
  if (file_name.size() <= kPrefix.size() + kSuffix.size()) return false;
  if (file_name.compare(0, kPrefix.size(), kPrefix) != 0) return false;
  if (file_name.compare(file_name.size() - kSuffix.size(), kSuffix.size(), kSuffix) != 0) {
    return false;
  }
  const std::string digits =
      file_name.substr(kPrefix.size(), file_name.size() - kPrefix.size() - kSuffix.size());
  if (digits.size() > 9 ||
      !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    return false;
  }
  *index = std::stoi(digits);
  return SevenScenesDataset::frameName(*index) + kSuffix == file_name;
}

// Frames that have a colour image or a pose but no depth image are not listed (a frame is its
// depth image): say so, naming the missing files, instead of dropping them silently.
std::vector<std::string> missingDepthWarnings(const fs::path& dir,
                                              const std::vector<int>& frame_indices) {
  const std::set<int> listed(frame_indices.begin(), frame_indices.end());
  std::set<int> without_depth;
  std::error_code error;
  for (fs::directory_iterator it(dir, error), end; !error && it != end; it.increment(error)) {
    const std::string file_name = it->path().filename().string();
    for (const std::string suffix : {".color.png", ".color.jpg", ".pose.txt"}) {
      if (file_name.size() <= suffix.size() ||
          file_name.compare(file_name.size() - suffix.size(), suffix.size(), suffix) != 0) {
        continue;
      }
      const std::string stem = file_name.substr(0, file_name.size() - suffix.size());
      int index = 0;
      if (parseDepthFileName(stem + ".depth.png", &index) && listed.count(index) == 0) {
        without_depth.insert(index);
      }
    }
  }
  if (without_depth.empty()) return {};
  const std::string names = nameFirstFrames(
      std::vector<int>(without_depth.begin(), without_depth.end()), kMaxNamedFrames,
      [](int index) { return SevenScenesDataset::frameName(index) + ".depth.png"; });
  return {dir.string() + ": " + std::to_string(without_depth.size()) +
          " frame(s) have a colour image or pose but no depth image and are skipped: missing " +
          names};
}

}  // namespace

double SevenScenesDataset::stampOf(int index) { return index / kFrameRateHz; }

std::string SevenScenesDataset::frameName(int index) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "frame-%06d", index);
  return buffer;
}

Status SevenScenesDataset::readMatrix3(const std::string& path, Eigen::Matrix3d* K) {
  std::vector<double> values;
  const Status status = readNumbers(path, 9, &values);
  if (!status) return status;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) (*K)(r, c) = values[3 * r + c];
  }
  return Status::Ok();
}

Status SevenScenesDataset::readPose(const std::string& path, Eigen::Isometry3d* T_W_C) {
  std::vector<double> values;
  const Status status = readNumbers(path, 16, &values);
  if (!status) return status;
  Eigen::Matrix4d M;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) M(r, c) = values[4 * r + c];
  }
  if ((M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-3) {
    return Status::Error(path + ": last row must be '0 0 0 1'");
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = M.topLeftCorner<3, 3>();
  T.translation() = M.topRightCorner<3, 1>();
  // The files hold printed decimals, so a rotation is only nearly orthonormal: accept small errors
  // and snap to the nearest rotation (SVD) so that downstream inverses stay exact.
  if (!isValidPose(T, 1e-2)) {
    return Status::Error(path +
                         ": not a rigid transform (the rotation is not orthonormal with "
                         "determinant +1)");
  }
  T.linear() = nearestRotation(T.linear());
  *T_W_C = T;
  return Status::Ok();
}

Status SevenScenesDataset::open(const std::string& directory, SevenScenesDataset* dataset,
                                const ColorCameraFiles& camera) {
  if (dataset == nullptr) return Status::Error("open: dataset is null");
  std::error_code error;
  if (!fs::exists(directory, error)) {
    return Status::Error(directory + ": dataset folder does not exist");
  }
  if (!fs::is_directory(directory, error)) {
    return Status::Error(directory + ": not a folder");
  }

  SevenScenesDataset result;
  result.directory_ = directory;
  const fs::path dir(directory);

  Eigen::Matrix3d K;
  const std::string depth_k_path = (dir / "camera-intrinsics.txt").string();
  Status status = readMatrix3(depth_k_path, &K);
  if (!status) return status;
  status = intrinsicsFromMatrix(depth_k_path, K, &result.K_depth_);
  if (!status) return status;

  // color-intrinsics.txt present: two cameras, masks (colour pixels) go through T_C_D and K_color.
  const fs::path color_k_path = camera.color_intrinsics.empty() ? dir / "color-intrinsics.txt"
                                                                : fs::path(camera.color_intrinsics);
  const fs::path depth_to_color_path =
      camera.depth_to_color.empty() ? dir / "depth-to-color.txt" : fs::path(camera.depth_to_color);
  if (camera.registered && !camera.color_intrinsics.empty()) {
    return Status::Error("a registered camera has no colour intrinsics of its own: give either");
  }
  for (const std::string& given : {camera.color_intrinsics, camera.depth_to_color}) {
    if (!given.empty() && !fs::is_regular_file(given, error)) {
      return Status::Error(given + ": no such file");
    }
  }
  if (!camera.registered && fs::exists(color_k_path, error)) {
    status = readMatrix3(color_k_path.string(), &K);
    if (!status) return status;
    status = intrinsicsFromMatrix(color_k_path.string(), K, &result.K_color_);
    if (!status) return status;
    result.registered_ = false;
    result.T_C_D_ = Eigen::Isometry3d::Identity();
    if (fs::exists(depth_to_color_path, error)) {
      status = readPose(depth_to_color_path.string(), &result.T_C_D_);
      if (!status) return status;
    }
  } else {
    if (!camera.registered && fs::exists(depth_to_color_path, error)) {
      return Status::Error(depth_to_color_path.string() +
                           ": given without color-intrinsics.txt (a registered dataset has one "
                           "camera)");
    }
    result.K_color_ = result.K_depth_;
    result.registered_ = true;
  }

  const fs::path gravity_path = dir / "gravity-direction.txt";
  if (fs::exists(gravity_path, error)) {
    std::vector<double> g;
    status = readNumbers(gravity_path.string(), 3, &g);
    if (!status) return status;
    // A direction in any unit (m/s^2, mm/s^2, a unit vector); a huge value would overflow the
    // norm and normalise to zero, which downstream means "estimate gravity".
    for (const double value : g) {
      if (std::abs(value) > kMaxGravityComponent) {
        char text[64];
        std::snprintf(text, sizeof(text), "%g", value);
        return Status::Error(gravity_path.string() + ": gravity component " + text +
                             " is out of range (|value| <= 1e6 expected); fix the file, or remove "
                             "it to estimate gravity from the floor");
      }
    }
    const Eigen::Vector3d gravity(g[0], g[1], g[2]);
    if (!(gravity.norm() > 1e-9)) {
      return Status::Error(gravity_path.string() +
                           ": gravity direction is zero; fix the file, or remove it to estimate "
                           "gravity from the floor");
    }
    result.gravity_down_W_ = gravity.normalized();
    result.has_gravity_ = true;
  }

  // A frame is one with a depth image; the colour image and pose are checked when it is loaded.
  for (fs::directory_iterator it(dir, error), end; !error && it != end; it.increment(error)) {
    int index = 0;
    if (parseDepthFileName(it->path().filename().string(), &index)) {
      result.frame_indices_.push_back(index);
    }
  }
  if (error) return Status::Error(directory + ": cannot list the folder: " + error.message());
  if (result.frame_indices_.empty()) {
    return Status::Error(directory + ": no frame-NNNNNN.depth.png files");
  }
  std::sort(result.frame_indices_.begin(), result.frame_indices_.end());
  result.warnings_ = missingDepthWarnings(dir, result.frame_indices_);
  result.probeImageSizes();

  *dataset = std::move(result);
  return Status::Ok();
}

void SevenScenesDataset::probeImageSizes() {
  const fs::path dir(directory_);
  for (size_t k = 0; k < frame_indices_.size() && k < kSizeProbeFrames; ++k) {
    const std::string stem = frameName(frame_indices_[k]);
    ImageHeader header;
    const fs::path depth_path = dir / (stem + ".depth.png");
    if (depth_size_.empty() && readImageFileHeader(depth_path.string(), &header) &&
        int64_t{header.size.width} * header.size.height <= kDefaultMaxImagePixels) {
      depth_size_ = header.size;
      depth_size_source_ = depth_path.filename().string();
    }
    // A JPEG may be turned by its EXIF orientation when decoded: its stored size says too little.
    const fs::path color_path = dir / (stem + ".color.png");
    if (color_size_.empty() && readImageFileHeader(color_path.string(), &header) &&
        int64_t{header.size.width} * header.size.height <= kDefaultMaxImagePixels) {
      color_size_ = header.size;
      color_size_source_ = color_path.filename().string();
    }
    if (!depth_size_.empty() && !color_size_.empty()) break;
  }
}

Status SevenScenesDataset::load(int index, RgbdFrame* frame) const {
  if (frame == nullptr) return Status::Error("load: frame is null");
  const fs::path dir(directory_);
  const std::string stem = frameName(index);

  fs::path color_path = dir / (stem + ".color.png");
  if (!isFile(color_path)) color_path = dir / (stem + ".color.jpg");
  if (!isFile(color_path)) {
    return Status::Error((dir / (stem + ".color.{png,jpg}")).string() + ": no such file");
  }
  const fs::path depth_path = dir / (stem + ".depth.png");
  if (!isFile(depth_path)) return Status::Error(depth_path.string() + ": no such file");
  const fs::path pose_path = dir / (stem + ".pose.txt");

  RgbdFrame result;
  result.index = index;
  result.name = stem;
  result.stamp_s = stampOf(index);

  Status status = readPose(pose_path.string(), &result.T_W_D);
  if (!status) return status;

  // Sizes are checked from the headers before anything is decoded (image bombs).
  status = readImageChecked(depth_path.string(), cv::IMREAD_UNCHANGED, depth_size_,
                            kDefaultMaxImagePixels, &result.depth,
                            "the depth camera's size, from " + depth_size_source_);
  if (!status) return status;
  if (result.depth.type() != CV_16UC1) {
    return Status::Error(depth_path.string() + ": depth is " + matTypeName(result.depth) +
                         ", expected 16-bit single channel (16UC1, millimetres)");
  }
  const cv::Size expected_color_size = registered_ ? result.depth.size() : color_size_;
  status = readImageChecked(color_path.string(), cv::IMREAD_COLOR, expected_color_size,
                            kDefaultMaxImagePixels, &result.color_bgr,
                            registered_ ? "the depth image's size: without color-intrinsics.txt "
                                          "colour and depth are registered"
                                        : "the colour camera's size, from " + color_size_source_);
  if (!status) return status;
  if (registered_ && result.color_bgr.size() != result.depth.size()) {
    return Status::Error(depth_path.string() + ": depth " + sizeText(result.depth) +
                         " but colour " + sizeText(result.color_bgr) + " (" +
                         color_path.filename().string() +
                         "); without color-intrinsics.txt colour and depth must be registered "
                         "and the same size");
  }

  result.K_depth = K_depth_;
  result.K_depth.width = result.depth.cols;
  result.K_depth.height = result.depth.rows;
  result.K_color = K_color_;
  result.K_color.width = result.color_bgr.cols;
  result.K_color.height = result.color_bgr.rows;
  result.registered = registered_;
  result.T_C_D = registered_ ? Eigen::Isometry3d::Identity() : T_C_D_;

  status = result.validate();
  if (!status) return status;
  *frame = std::move(result);
  return Status::Ok();
}

}  // namespace mvod
