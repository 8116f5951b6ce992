// One RGB-D keyframe as the core sees it.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "multiview_object_detection/pipeline/common.h"

namespace mvod {

struct RgbdFrame {
  int index = 0;           // frame number in its sequence
  std::string name;        // e.g. "frame-000010"; used by file-based detectors and in messages
  double stamp_s = 0.0;    // time stamp (s)
  cv::Mat color_bgr;       // CV_8UC3
  cv::Mat depth;           // CV_16UC1 (millimetres) or CV_32FC1 (metres)
  CameraIntrinsics K_depth;  // intrinsics of the depth image
  CameraIntrinsics K_color;  // intrinsics of the colour image
  // False when colour and depth come from two cameras (7-Scenes, a Kinect without hardware registration):
  // masks in colour pixels are then applied through T_C_D and K_color, not pixel by pixel.
  bool registered = true;
  Eigen::Isometry3d T_C_D = Eigen::Isometry3d::Identity();  // depth camera -> colour camera
  Eigen::Isometry3d T_W_D = Eigen::Isometry3d::Identity();  // depth camera -> world (Eq. 1's T_n)

  // Checks types, sizes, intrinsics and pose; the message names the frame.
  Status validate() const;
};

}  // namespace mvod
