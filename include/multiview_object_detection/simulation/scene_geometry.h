// Angles and rotations of the synthetic scenes (world z up).
#pragma once

#include <Eigen/Geometry>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {
namespace simulation {

using mvod::kPi;  // pipeline/types/common.h

inline double deg2rad(double deg) { return deg * kPi / 180.0; }

// Rotation about the world's z axis (up).
inline Eigen::Matrix3d yawRotation(double yaw_rad) {
  return Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

}  // namespace simulation
}  // namespace mvod
