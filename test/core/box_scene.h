// A minimal ray-cast world for core tests: z up, floor z = 0, a wall at y = wall_y_m, and (when
// with_box) one box yawed about z standing on the floor. Shared by the LCCP and mapper tests.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/class_priors.h"
#include "multiview_object_detection/pipeline/types/detection.h"
#include "multiview_object_detection/pipeline/types/rgbd_frame.h"

namespace mvod {
namespace test {

enum class Surface { kNone, kFloor, kWall, kBox };

struct BoxScene {
  Eigen::Vector3d box_center = Eigen::Vector3d(0.0, 2.0, 0.25);
  Eigen::Vector3d box_half_size = Eigen::Vector3d(0.25, 0.2, 0.25);  // 0.5 x 0.4 x 0.5 m
  double box_yaw_rad = 0.0;
  double wall_y_m = 2.5;
  bool with_box = true;

  Eigen::Matrix3d boxRotation() const {
    return Eigen::AngleAxisd(box_yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  }

  std::vector<Eigen::Vector3d> boxCorners() const {
    std::vector<Eigen::Vector3d> corners;
    for (int i = 0; i < 8; ++i) {
      const Eigen::Vector3d sign((i & 1) ? 1 : -1, (i & 2) ? 1 : -1, (i & 4) ? 1 : -1);
      corners.push_back(box_center + boxRotation() * sign.cwiseProduct(box_half_size));
    }
    return corners;
  }

  // Distance along the ray (o + t d) to the nearest surface (infinity for none), and which it is.
  double cast(const Eigen::Vector3d& o, const Eigen::Vector3d& d, Surface* surface) const {
    double best = std::numeric_limits<double>::infinity();
    *surface = Surface::kNone;
    if (d.z() < -1e-9) {
      best = -o.z() / d.z();
      *surface = Surface::kFloor;
    }
    if (d.y() > 1e-9 && (wall_y_m - o.y()) / d.y() < best) {
      best = (wall_y_m - o.y()) / d.y();
      *surface = Surface::kWall;
    }
    if (!with_box) return best;
    // Slab test in the box frame.
    const Eigen::Matrix3d R = boxRotation();
    const Eigen::Vector3d o_B = R.transpose() * (o - box_center);
    const Eigen::Vector3d d_B = R.transpose() * d;
    double t_near = -std::numeric_limits<double>::infinity();
    double t_far = std::numeric_limits<double>::infinity();
    for (int i = 0; i < 3; ++i) {
      if (std::abs(d_B[i]) < 1e-12) {
        if (std::abs(o_B[i]) > box_half_size[i]) return best;
        continue;
      }
      double t1 = (-box_half_size[i] - o_B[i]) / d_B[i];
      double t2 = (box_half_size[i] - o_B[i]) / d_B[i];
      if (t1 > t2) std::swap(t1, t2);
      t_near = std::max(t_near, t1);
      t_far = std::min(t_far, t2);
    }
    if (t_near <= t_far && t_near > 0.0 && t_near < best) {
      best = t_near;
      *surface = Surface::kBox;
    }
    return best;
  }
};

// Camera optical frame (x right, y down, z forward) at `position`, looking along world +y, pitched
// down by pitch_deg.
inline Eigen::Isometry3d cameraLookingAlongY(const Eigen::Vector3d& position, double pitch_deg) {
  const double p = pitch_deg * 3.14159265358979323846 / 180.0;
  Eigen::Matrix3d R;
  R.col(0) = Eigen::Vector3d(1, 0, 0);
  R.col(1) = Eigen::Vector3d(0, -std::sin(p), -std::cos(p));
  R.col(2) = Eigen::Vector3d(0, std::cos(p), -std::sin(p));
  Eigen::Isometry3d T_W_C = Eigen::Isometry3d::Identity();
  T_W_C.linear() = R;
  T_W_C.translation() = position;
  return T_W_C;
}

// Renders a 640x480 frame (16-bit mm depth, Kinect-like intrinsics) and the perfect mask of the
// box. (At 320x240 the grazing-angle box top is sampled too sparsely for 1-2 cm supervoxels.)
inline RgbdFrame renderFrame(const BoxScene& scene, const Eigen::Isometry3d& T_W_D, int index,
                             cv::Mat* mask) {
  RgbdFrame frame;
  frame.index = index;
  frame.name = "frame-" + std::to_string(index);
  frame.stamp_s = 0.1 * index;
  frame.K_depth = CameraIntrinsics{520.0, 520.0, 319.5, 239.5, 640, 480};
  frame.K_color = frame.K_depth;
  frame.registered = true;
  frame.T_W_D = T_W_D;
  frame.depth = cv::Mat(480, 640, CV_16UC1, cv::Scalar(0));
  frame.color_bgr = cv::Mat(480, 640, CV_8UC3, cv::Scalar(90, 120, 150));
  *mask = cv::Mat(480, 640, CV_8UC1, cv::Scalar(0));
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      const Eigen::Vector3d ray_D((u - frame.K_depth.cx) / frame.K_depth.fx,
                                  (v - frame.K_depth.cy) / frame.K_depth.fy, 1.0);
      Surface surface = Surface::kNone;
      const double t = scene.cast(T_W_D.translation(), T_W_D.linear() * ray_D, &surface);
      const bool on_box = surface == Surface::kBox;
      if (!std::isfinite(t) || t > 10.0) continue;
      frame.depth.at<uint16_t>(v, u) = static_cast<uint16_t>(std::lround(t * 1000.0));
      if (on_box) {
        mask->at<uint8_t>(v, u) = 255;
        frame.color_bgr.at<cv::Vec3b>(v, u) = cv::Vec3b(20, 40, 200);
      }
    }
  }
  return frame;
}

inline Detection2D detectionFromMask(const cv::Mat& mask, const std::string& class_name,
                                     float score) {
  Detection2D detection;
  detection.class_name = class_name;
  detection.class_id = cocoClassId(class_name);
  detection.score = score;
  detection.mask = mask.clone();
  detection.box_px = cv::boundingRect(mask);
  return detection;
}

}  // namespace test
}  // namespace mvod
