// One RGB-D keyframe as the core sees it.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {

struct RgbdFrame {
  int index = 0;             // frame number in its sequence
  std::string name;          // e.g. "frame-000010"; used by file-based detectors and in messages
  double stamp_s = 0.0;      // time stamp (s)
  cv::Mat color_bgr;         // CV_8UC3
  cv::Mat depth;             // CV_16UC1 (millimetres) or CV_32FC1 (metres)
  CameraIntrinsics K_depth;  // intrinsics of the depth image
  CameraIntrinsics K_color;  // intrinsics of the colour image
  // False when colour and depth come from two cameras (7-Scenes, a Kinect without hardware
  // registration): masks in colour pixels are then applied through T_C_D and K_color, not pixel by
  // pixel.
  bool registered = true;
  Eigen::Isometry3d T_C_D = Eigen::Isometry3d::Identity();  // depth camera -> colour camera
  Eigen::Isometry3d T_W_D = Eigen::Isometry3d::Identity();  // depth camera -> world (Eq. 1's T_n)

  // Checks types, sizes, intrinsics and pose; the message names the frame.
  Status validate() const;
};

// "8UC1", "16UC1", "32FC3", ...: an image type short enough for a one-line message.
std::string matTypeName(const cv::Mat& m);
// "640x480".
std::string sizeText(int width, int height);

// The colour pixel (nearest, pixel centres at integer coordinates) that a point of the depth
// camera frame projects to through T_C_D and K_color. False behind the colour camera or outside
// the colour image. The one place where depth points meet colour masks (Eq. 1 for two cameras).
inline bool colorPixelOf(const RgbdFrame& frame, const Eigen::Vector3d& p_D, cv::Point* pixel) {
  const Eigen::Vector3d p_C = frame.T_C_D * p_D;
  if (!(p_C.z() > 0.0)) return false;
  const CameraIntrinsics& K = frame.K_color;
  const double u = std::floor(K.fx * p_C.x() / p_C.z() + K.cx + 0.5);
  const double v = std::floor(K.fy * p_C.y() / p_C.z() + K.cy + 0.5);
  if (!(u >= 0.0 && v >= 0.0 && u < frame.color_bgr.cols && v < frame.color_bgr.rows)) return false;
  *pixel = cv::Point(static_cast<int>(u), static_cast<int>(v));
  return true;
}

}  // namespace mvod
