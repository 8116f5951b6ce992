// A keyframe's depth image with its camera, for tests of world points against what the view
// measured: evidence fusion's projective signed distance (ObjectDatabase) and the free space of
// amodal completion (AmodalCompletion).
#pragma once

#include <Eigen/Geometry>
#include <memory>
#include <opencv2/core.hpp>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {

// The projective signed distance of a voxel: the depth measured at its pixel minus the voxel's own
// depth, positive in front of the surface the view saw (the distance a TSDF averages). At a depth
// edge (the 3 x 3 pixels around the voxel's pixel not all valid, or spanning more than the
// truncation) the view abstains.
struct DepthView {
  cv::Mat depth_m;  // CV_32FC1, 0 = invalid
  CameraIntrinsics K;
  Eigen::Isometry3d T_D_W = Eigen::Isometry3d::Identity();  // world -> depth camera
  // Truncation: further in front of the measured surface counts as this much (the view saw
  // through the voxel); further behind it is occluded and not counted.
  double truncation_m = 0.02;
  double truncation_per_m2 = 8.55e-3;  // ... plus this x depth^2 (3 Kinect v1 depth steps)
  // The truncated signed distance of p_W; false outside the image, behind the camera, where the
  // depth is invalid, and where p_W lies beyond the truncation behind the surface.
  bool signedDistance(const Eigen::Vector3f& p_W, float* sdf_m) const;

  // Optional, for views that test many points: the lowest and highest depth of each pixel's 3 x 3
  // neighbourhood (clamped at the border; lowest 0 where one of them is invalid), so that
  // signedDistance reads two pixels instead of nine. Computed by prepareNeighbourhoods() from
  // depth_m (call it again after changing depth_m); the same results with or without it.
  cv::Mat lowest_3x3_m;
  cv::Mat highest_3x3_m;
  void prepareNeighbourhoods();

  // What the view saw at p_W, the one visibility model of amodal completion's free space and of the
  // objects' existence evidence: kNotInView outside the image, behind the camera, or without valid
  // depth at its pixel; kSeenFree when the pixel's depth lies more than margin_m plus the
  // truncation at p_W's depth beyond it (the view saw through it); kHidden when the measured
  // surface lies more than the truncation in front of it (something nearer hides it); kOnSurface
  // otherwise (the depth lies on it).
  enum class Visibility { kNotInView, kSeenFree, kOnSurface, kHidden };
  Visibility visibility(const Eigen::Vector3f& p_W, double margin_m) const;
};

// The keyframe's depth as DepthView measures it: metres, 0 where invalid or outside [min_m, max_m],
// with its 3 x 3 ranges prepared, at pose T_W_D.
std::shared_ptr<DepthView> makeDepthView(const cv::Mat& depth, const CameraIntrinsics& K_depth,
                                         const Eigen::Isometry3d& T_W_D, double min_valid_m,
                                         double max_valid_m, double truncation_m,
                                         double truncation_per_m2);

}  // namespace mvod
