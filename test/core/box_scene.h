// A minimal ray-cast world for core tests: z up, floor z = 0, a wall at y = wall_y_m, and (when
// with_box) one box yawed about z standing on the floor. Shared by the LCCP and mapper tests.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

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

}  // namespace test
}  // namespace mvod
