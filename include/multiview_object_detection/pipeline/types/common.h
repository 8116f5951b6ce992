// Basic types shared by every stage of the core library. No ROS and no PCL here: PCL stays inside
// the .cpp files of the stages that need it, so this header is cheap to include.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <cstddef>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace mvod {

// pi (M_PI is not standard C++).
constexpr double kPi = 3.14159265358979323846;

// A point cloud is a plain vector of 3D points; the frame is carried by the variable name
// (points_C: camera optical frame, points_W: world frame). Eigen::Vector3f is not a vectorisable
// fixed-size type, so no aligned allocator is needed.
using PointCloud = std::vector<Eigen::Vector3f>;

// Result of an operation that can fail on bad input. The core never logs: it returns a Status and
// the caller (offline runner, ROS node) reports it.
class Status {
 public:
  Status() = default;
  static Status Ok() { return Status(); }
  static Status Error(std::string message) { return Status(std::move(message)); }
  bool ok() const { return ok_; }
  explicit operator bool() const { return ok_; }
  const std::string& message() const { return message_; }

 private:
  explicit Status(std::string message) : ok_(false), message_(std::move(message)) {}
  bool ok_ = true;
  std::string message_;
};

// Pinhole intrinsics of one camera (pixels). width/height of 0 mean "unknown".
struct CameraIntrinsics {
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
  int width = 0;
  int height = 0;

  bool isValid() const { return fx > 0.0 && fy > 0.0 && std::isfinite(cx) && std::isfinite(cy); }
  Eigen::Matrix3d K() const {
    Eigen::Matrix3d k;
    k << fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0;
    return k;
  }
};

// Transform a cloud: points_B = T_B_A * points_A.
PointCloud transformCloud(const PointCloud& points_A, const Eigen::Isometry3d& T_B_A);

// The rotation nearest to M (SVD, determinant +1): for matrices read from text files, which are
// only nearly orthonormal.
Eigen::Matrix3d nearestRotation(const Eigen::Matrix3d& M);

// std::fmod(x, y) for y > 0, bit for bit, without the library call where |x| < 16 y (angles
// folded into a quarter turn): the multiples 8y, 4y, 2y, y are exact, and each subtraction from a
// remainder between one and two of them is exact (Sterbenz), so the result is the exact remainder
// that fmod returns, with x's sign.
inline double fmodSmall(double x, double y) {
  const double magnitude = std::abs(x);
  if (!(magnitude < 16.0 * y) || !(y > 0.0)) return std::fmod(x, y);
  double r = magnitude;
  for (double multiple = 8.0 * y; multiple >= y; multiple *= 0.5) {
    if (r >= multiple) r -= multiple;
  }
  return std::copysign(r, x);
}

// True if every element of the matrix is finite and its rotation part is orthonormal within tol.
bool isValidPose(const Eigen::Isometry3d& T, double tol = 1e-3);

}  // namespace mvod
