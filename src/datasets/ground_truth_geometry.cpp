#include "multiview_object_detection/datasets/ground_truth_geometry.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "multiview_object_detection/pipeline/stages/box_estimator.h"

namespace mvod {

PointCloud sampleBoxSurface(const OrientedBox& box, double spacing_m, const Eigen::Vector3d& up_W) {
  PointCloud points;
  if (!(spacing_m > 0.0) || !std::isfinite(spacing_m) || !box.center_m.allFinite() ||
      !box.size_m.allFinite() || !box.rotation.allFinite() || (box.size_m.array() < 0.0).any()) {
    return points;
  }
  const Eigen::Vector3d up =
      up_W.allFinite() && up_W.norm() > 1e-9 ? up_W.normalized() : Eigen::Vector3d::UnitZ();
  constexpr int kMaxSteps = 2000;  // bounds memory for absurd boxes
  auto steps = [&](double extent) {
    return std::clamp(static_cast<int>(std::ceil(extent / spacing_m)), 1, kMaxSteps);
  };
  for (int axis = 0; axis < 3; ++axis) {
    for (const double sign : {-1.0, 1.0}) {
      const Eigen::Vector3d normal = sign * box.rotation.col(axis);
      if (normal.dot(up) < -0.9) continue;  // the bottom face
      const int j = (axis + 1) % 3;
      const int k = (axis + 2) % 3;
      const int nj = steps(box.size_m[j]);
      const int nk = steps(box.size_m[k]);
      for (int a = 0; a <= nj; ++a) {
        for (int b = 0; b <= nk; ++b) {
          Eigen::Vector3d local;
          local[axis] = 0.5 * sign * box.size_m[axis];
          local[j] = box.size_m[j] * (static_cast<double>(a) / nj - 0.5);
          local[k] = box.size_m[k] * (static_cast<double>(b) / nk - 0.5);
          points.push_back((box.center_m + box.rotation * local).cast<float>());
        }
      }
    }
  }
  return points;
}

OrientedBox fitGravityAlignedBox(const PointCloud& points_W, const Eigen::Vector3d& up_W) {
  OrientedBox box;
  const GravityFrame frame(up_W.allFinite() && up_W.norm() > 1e-9 ? Eigen::Vector3d(-up_W)
                                                                  : Eigen::Vector3d(0, 0, -1));
  BoxEstimator::Config manhattan;
  manhattan.extent_trim_fraction = 0.0;      // ground truth: the whole surface
  manhattan.footprint_yaw_area_ratio = 0.0;  // (the ground truth of earlier releases)
  manhattan.outline_cell_m = 0.0;
  manhattan.normal_estimation = "radius";  // per point, as for the ground truth before
  if (points_W.size() >= 200 && BoxEstimator(manhattan).estimate(points_W, frame, &box).ok()) {
    return box;
  }
  box = OrientedBox();
  std::vector<Eigen::Vector2d> footprint;
  double low = std::numeric_limits<double>::infinity();
  double high = -std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3f& pf : points_W) {
    if (!pf.allFinite()) continue;
    const Eigen::Vector3d p = pf.cast<double>();
    footprint.emplace_back(p.dot(frame.x_h), p.dot(frame.y_h));
    low = std::min(low, p.dot(frame.up));
    high = std::max(high, p.dot(frame.up));
  }
  if (footprint.empty()) return box;
  const Rectangle2d rectangle = minimumAreaRectangle(footprint);
  box.center_m = rectangle.center.x() * frame.x_h + rectangle.center.y() * frame.y_h +
                 0.5 * (low + high) * frame.up;
  box.size_m = Eigen::Vector3d(rectangle.size.x(), rectangle.size.y(), high - low);
  box.rotation = frame.rotationFromYaw(rectangle.yaw_rad);
  return box;
}

}  // namespace mvod
