// What passes between the node's stages: a checked RGB-D input on its way to the keyframe buffer,
// and a keyframe on its way to the worker.
#pragma once

#include <Eigen/Geometry>
#include <chrono>
#include <string>

#include "multiview_object_detection/ros/conversions.h"

namespace mvod {

// A synchronised input that passed the header checks, waiting for its pose (and, in keyframe_mode
// topic, its keyframe message).
struct PendingFrame {
  RgbdMessages msgs;
  std::string camera_frame;
  std::chrono::steady_clock::time_point received;
};

// A keyframe waiting for the worker.
struct KeyframeJob {
  RgbdMessages msgs;
  std::string camera_frame;
  Eigen::Isometry3d T_W_C = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_C_D = Eigen::Isometry3d::Identity();
  std::chrono::steady_clock::time_point received;
  int index = 0;
};

}  // namespace mvod
