// A dataset folder in the 7-Scenes layout:
//   frame-NNNNNN.color.{jpg,png}, frame-NNNNNN.depth.png (16-bit mm), frame-NNNNNN.pose.txt (4x4 camera to
//   world, row-major), camera-intrinsics.txt (3x3 depth K), optional color-intrinsics.txt (3x3; present =
//   colour not registered to depth), optional gravity-direction.txt (world gravity, pointing down).
#pragma once

#include <string>
#include <vector>

#include "multiview_object_detection/rgbd_frame.h"

namespace mvod {

class SevenScenesDataset {
 public:
  // Lists the frames and reads the intrinsics; fails on a missing folder or camera-intrinsics.txt.
  static Status open(const std::string& directory, SevenScenesDataset* dataset);

  size_t size() const { return frame_indices_.size(); }
  const std::vector<int>& frameIndices() const { return frame_indices_; }
  static std::string frameName(int index);  // "frame-000010"
  // Loads one frame (images, pose); the message names the file on any problem.
  Status load(int index, RgbdFrame* frame) const;

  const std::string& directory() const { return directory_; }
  const CameraIntrinsics& depthIntrinsics() const { return K_depth_; }
  const CameraIntrinsics& colorIntrinsics() const { return K_color_; }
  bool registered() const { return registered_; }
  bool hasGravity() const { return has_gravity_; }
  Eigen::Vector3d gravityDown_W() const { return gravity_down_W_; }

  // File parsers, public for tests.
  static Status readMatrix3(const std::string& path, Eigen::Matrix3d* K);
  static Status readPose(const std::string& path, Eigen::Isometry3d* T_W_C);

 private:
  std::string directory_;
  std::vector<int> frame_indices_;
  CameraIntrinsics K_depth_;
  CameraIntrinsics K_color_;
  bool registered_ = true;
  bool has_gravity_ = false;
  Eigen::Vector3d gravity_down_W_ = Eigen::Vector3d(0, 0, -1);
};

}  // namespace mvod
