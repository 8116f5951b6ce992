// Gravity ("down" in the world frame) from the dominant horizontal plane, then as all the frame's
// surfaces agree on it (docs/method.md), for when no gravity is configured (ORB-SLAM2's map frame
// is its first camera's frame, not gravity-aligned).
#pragma once

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {

class GravityEstimator {
 public:
  struct Config {
    double plane_distance_threshold_m = 0.02;  // RANSAC inlier distance
    int ransac_iterations = 300;
    // A plane counts as horizontal when its normal is within this angle of the camera's "up" (-y of
    // the optical frame): robot cameras look roughly level, so floor and table tops face camera-up.
    double max_tilt_from_camera_up_deg = 35.0;
    double min_plane_fraction = 0.1;  // fraction of the frame's points the plane must hold
    double voxel_size_m = 0.05;
    Status isValid() const;
    std::string print() const;
  };

  GravityEstimator() = default;
  explicit GravityEstimator(const Config& config) : config_(config) {}

  // Adds one frame (whole depth cloud, depth-camera frame, and its pose). Returns true once an
  // estimate is available.
  bool addFrame(const PointCloud& points_D, const Eigen::Isometry3d& T_W_D);
  bool hasEstimate() const { return has_estimate_; }
  // Unit gravity (pointing down) in the world frame.
  Eigen::Vector3d gravityDown_W() const { return gravity_W_; }
  int supportingPoints() const { return best_support_; }

 private:
  Config config_;
  bool has_estimate_ = false;
  Eigen::Vector3d gravity_W_ = Eigen::Vector3d(0, 0, -1);
  int best_support_ = 0;
};

}  // namespace mvod
