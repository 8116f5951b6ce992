// A dataset folder in the 7-Scenes layout:
//   frame-NNNNNN.color.{jpg,png}, frame-NNNNNN.depth.png (16-bit mm), frame-NNNNNN.pose.txt (4x4
//   camera to world, row-major), camera-intrinsics.txt (3x3 depth K), optional color-intrinsics.txt
//   (3x3; present = colour not registered to depth), optional depth-to-color.txt (4x4 depth camera
//   -> colour camera, row-major, T_C_D; only with color-intrinsics.txt; identity when absent),
//   optional gravity-direction.txt (3 numbers: world gravity, pointing down; normalised on
//   reading).
// A frame is listed when its frame-NNNNNN.depth.png exists; its colour image (.png or .jpg) and
// pose are checked by load(). Frames with a colour image or pose but no depth image are skipped
// with a warning (warnings()). Time stamps are index / 30 s (7-Scenes is 30 Hz).
// Image sizes: open() reads the headers (no decoding) of the first frames to learn each camera's
// image size; load() refuses, before decoding, an image of another size or above
// kDefaultMaxImagePixels (io/image_io.h), so a small PNG claiming 20000x20000 pixels costs nothing.
#pragma once

#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/rgbd_frame.h"

namespace mvod {

// The colour camera's files given apart from the dataset folder (which may be read-only): empty
// paths = the folder's color-intrinsics.txt and depth-to-color.txt. registered: colour and depth
// are one camera (the folder's colour files are not read).
struct ColorCameraFiles {
  std::string color_intrinsics;
  std::string depth_to_color;
  bool registered = false;
  bool empty() const { return color_intrinsics.empty() && depth_to_color.empty() && !registered; }
};

class SevenScenesDataset {
 public:
  // Lists the frames and reads the intrinsics; fails on a missing folder or camera-intrinsics.txt.
  static Status open(const std::string& directory, SevenScenesDataset* dataset,
                     const ColorCameraFiles& camera = {});

  size_t size() const { return frame_indices_.size(); }
  const std::vector<int>& frameIndices() const { return frame_indices_; }
  static std::string frameName(int index);  // "frame-000010"
  static double stampOf(int index);         // index / 30 s, as load() gives it
  // Loads one frame (images, pose); the message names the file on any problem.
  Status load(int index, RgbdFrame* frame) const;

  const std::string& directory() const { return directory_; }
  const CameraIntrinsics& depthIntrinsics() const { return K_depth_; }
  const CameraIntrinsics& colorIntrinsics() const { return K_color_; }
  bool registered() const { return registered_; }
  // Depth camera -> colour camera (identity when registered or without depth-to-color.txt).
  const Eigen::Isometry3d& depthToColor() const { return T_C_D_; }
  // What may make the results wrong, found by open() (e.g. frames skipped for a missing depth
  // image).
  const std::vector<std::string>& warnings() const { return warnings_; }
  bool hasGravity() const { return has_gravity_; }
  Eigen::Vector3d gravityDown_W() const { return gravity_down_W_; }

  // File parsers, public for tests. readMatrix3: exactly 9 finite numbers. readPose: exactly 16
  // finite numbers, last row 0 0 0 1 (within 1e-3), a rigid transform within 1e-2; the rotation is
  // then re-orthonormalised. The message names the file.
  static Status readMatrix3(const std::string& path, Eigen::Matrix3d* K);
  static Status readPose(const std::string& path, Eigen::Isometry3d* T_W_C);

 private:
  // Sets depth_size_ / color_size_ from the first frames' image headers (PNG, or JPEG colour).
  void probeImageSizes();

  std::string directory_;
  std::vector<int> frame_indices_;
  CameraIntrinsics K_depth_;
  CameraIntrinsics K_color_;
  bool registered_ = true;
  Eigen::Isometry3d T_C_D_ = Eigen::Isometry3d::Identity();
  bool has_gravity_ = false;
  Eigen::Vector3d gravity_down_W_ = Eigen::Vector3d(0, 0, -1);
  std::vector<std::string> warnings_;
  // Each camera's image size and the file it was read from (empty = unknown: any size within
  // kDefaultMaxImagePixels).
  cv::Size depth_size_;
  std::string depth_size_source_;
  cv::Size color_size_;
  std::string color_size_source_;
};

}  // namespace mvod
