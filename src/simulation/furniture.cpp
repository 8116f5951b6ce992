#include "multiview_object_detection/simulation/furniture.h"

#include <limits>

#include "multiview_object_detection/simulation/scene_geometry.h"

namespace mvod {
namespace simulation {

LocalPart part(double x0, double y0, double z0, double x1, double y1, double z1) {
  return {Eigen::Vector3d(x0, y0, z0), Eigen::Vector3d(x1, y1, z1)};
}

SyntheticObject assemble(const std::string& name, const Eigen::Vector3d& origin_W, double yaw,
                         const std::vector<LocalPart>& parts) {
  SyntheticObject object;
  object.class_name = name;
  const Eigen::Matrix3d R = yawRotation(yaw);
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const LocalPart& local : parts) {
    OrientedBox box;
    box.rotation = R;
    box.size_m = local.hi - local.lo;
    box.center_m = origin_W + R * (0.5 * (local.lo + local.hi));
    object.parts.push_back(box);
    lo = lo.cwiseMin(local.lo);
    hi = hi.cwiseMax(local.hi);
  }
  object.box.rotation = R;
  object.box.size_m = hi - lo;
  object.box.center_m = origin_W + R * (0.5 * (lo + hi));
  if (parts.size() == 1) object.parts.clear();  // the box is the one part
  return object;
}

std::vector<LocalPart> chairParts(double w, double d, double seat_h, double h) {
  const double t = 0.04;  // legs and seat
  std::vector<LocalPart> parts;
  for (const double sx : {-1.0, 1.0}) {
    for (const double sy : {-1.0, 1.0}) {
      const double x = sx * (0.5 * w - 0.5 * t);
      const double y = sy * (0.5 * d - 0.5 * t);
      parts.push_back(part(x - 0.5 * t, y - 0.5 * t, 0.0, x + 0.5 * t, y + 0.5 * t, seat_h - t));
    }
  }
  parts.push_back(part(-0.5 * w, -0.5 * d, seat_h - t, 0.5 * w, 0.5 * d, seat_h));
  parts.push_back(part(-0.5 * w, -0.5 * d, seat_h, 0.5 * w, -0.5 * d + 0.05, h));  // back
  return parts;
}

std::vector<LocalPart> tableParts(double w, double d, double h) {
  const double leg = 0.06;
  const double top = 0.04;
  std::vector<LocalPart> parts;
  parts.push_back(part(-0.5 * w, -0.5 * d, h - top, 0.5 * w, 0.5 * d, h));
  for (const double sx : {-1.0, 1.0}) {
    for (const double sy : {-1.0, 1.0}) {
      const double x = sx * (0.5 * w - 0.05 - 0.5 * leg);
      const double y = sy * (0.5 * d - 0.05 - 0.5 * leg);
      parts.push_back(
          part(x - 0.5 * leg, y - 0.5 * leg, 0.0, x + 0.5 * leg, y + 0.5 * leg, h - top));
    }
  }
  return parts;
}

std::vector<LocalPart> couchParts(double w, double d, double h) {
  const double seat_h = 0.42;
  const double back = 0.22;
  const double arm = 0.18;
  return {part(-0.5 * w, -0.5 * d, 0.0, 0.5 * w, 0.5 * d, seat_h),
          part(-0.5 * w, -0.5 * d, seat_h, 0.5 * w, -0.5 * d + back, h),
          part(-0.5 * w, -0.5 * d + back, seat_h, -0.5 * w + arm, 0.5 * d, seat_h + 0.2),
          part(0.5 * w - arm, -0.5 * d + back, seat_h, 0.5 * w, 0.5 * d, seat_h + 0.2)};
}

std::vector<LocalPart> bedParts(double w, double l) {
  const double head = 0.08;
  return {part(-0.5 * w, -0.5 * l + head, 0.0, 0.5 * w, 0.5 * l, 0.3),
          part(-0.5 * w + 0.03, -0.5 * l + head + 0.02, 0.3, 0.5 * w - 0.03, 0.5 * l - 0.03, 0.52),
          part(-0.5 * w, -0.5 * l, 0.0, 0.5 * w, -0.5 * l + head, 1.05)};
}

std::vector<LocalPart> tvParts(double w, double h) {
  return {part(-0.15, -0.1, 0.0, 0.15, 0.1, 0.02), part(-0.03, -0.02, 0.02, 0.03, 0.02, 0.1),
          part(-0.5 * w, -0.03, 0.1, 0.5 * w, 0.03, 0.1 + h)};
}

std::vector<LocalPart> fridgeParts(double w, double d, double h) {
  const double handle_x = 0.5 * w - 0.1;
  return {part(-0.5 * w, -0.5 * d, 0.0, 0.5 * w, 0.5 * d - 0.03, h),
          part(handle_x, 0.5 * d - 0.03, 0.45, handle_x + 0.03, 0.5 * d, 0.85),
          part(handle_x, 0.5 * d - 0.03, 1.05, handle_x + 0.03, 0.5 * d, 1.55)};
}

std::vector<LocalPart> cupParts() {
  return {part(-0.04, -0.04, 0.0, 0.04, 0.04, 0.095), part(0.04, -0.01, 0.025, 0.06, 0.01, 0.07)};
}

std::vector<LocalPart> shelfParts(double w, double d, double h, int levels, double* spacing) {
  const double t = 0.02;
  *spacing = (h - t) / levels;
  std::vector<LocalPart> parts = {
      part(-0.5 * w, -0.5 * d, 0.0, -0.5 * w + t, 0.5 * d, h),
      part(0.5 * w - t, -0.5 * d, 0.0, 0.5 * w, 0.5 * d, h),
      part(-0.5 * w + t, -0.5 * d, 0.0, 0.5 * w - t, -0.5 * d + 0.01, h)};
  for (int i = 0; i <= levels; ++i) {
    parts.push_back(
        part(-0.5 * w + t, -0.5 * d + 0.01, i * *spacing, 0.5 * w - t, 0.5 * d, i * *spacing + t));
  }
  return parts;
}

SyntheticObject makeChair(SplitMix64& rng, const Eigen::Vector3d& origin, double yaw) {
  const double w = rng.uniform(0.42, 0.5);
  const double d = rng.uniform(0.44, 0.52);
  return assemble("chair", origin, yaw,
                  chairParts(w, d, rng.uniform(0.43, 0.48), rng.uniform(0.82, 0.95)));
}

}  // namespace simulation
}  // namespace mvod
