#include "multiview_object_detection/pipeline/depth_view.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mvod {

bool DepthView::signedDistance(const Eigen::Vector3f& p_W, float* sdf_m) const {
  const Eigen::Vector3d p_D = T_D_W * p_W.cast<double>();
  if (!(p_D.z() > 0.0) || depth_m.empty() || depth_m.type() != CV_32FC1) return false;
  const double u = std::floor(K.fx * p_D.x() / p_D.z() + K.cx + 0.5);
  const double v = std::floor(K.fy * p_D.y() / p_D.z() + K.cy + 0.5);
  if (!(u >= 0.0 && v >= 0.0 && u < depth_m.cols && v < depth_m.rows)) return false;
  // A depth edge (a silhouette: a chair's leg before the wall) abstains: a voxel of the leg that
  // rounds to a pixel beside it would look seen through. The pixel and its 8 neighbours must all
  // have a depth, within the truncation of each other.
  const double z = p_D.z();
  const double truncation = truncation_m + truncation_per_m2 * z * z;
  const int u0 = static_cast<int>(u);
  const int v0 = static_cast<int>(v);
  float lowest = std::numeric_limits<float>::infinity();
  float highest = 0.f;
  for (int dv = -1; dv <= 1; ++dv) {
    const int row = std::min(std::max(v0 + dv, 0), depth_m.rows - 1);
    const float* depths = depth_m.ptr<float>(row);
    for (int du = -1; du <= 1; ++du) {
      const float measured = depths[std::min(std::max(u0 + du, 0), depth_m.cols - 1)];
      if (!(measured > 0.f) || !std::isfinite(measured)) return false;
      lowest = std::min(lowest, measured);
      highest = std::max(highest, measured);
    }
  }
  if (highest - lowest > truncation) return false;
  const double sdf = static_cast<double>(depth_m.ptr<float>(v0)[u0]) - z;
  if (sdf < -truncation) return false;
  *sdf_m = static_cast<float>(std::min(sdf, truncation));
  return true;
}

DepthView::Visibility DepthView::visibility(const Eigen::Vector3f& p_W, double margin_m) const {
  const Eigen::Vector3d p_D = T_D_W * p_W.cast<double>();
  if (!(p_D.z() > 0.0) || depth_m.empty() || depth_m.type() != CV_32FC1) {
    return Visibility::kNotInView;
  }
  const double u = std::floor(K.fx * p_D.x() / p_D.z() + K.cx + 0.5);
  const double v = std::floor(K.fy * p_D.y() / p_D.z() + K.cy + 0.5);
  if (!(u >= 0.0 && v >= 0.0 && u < depth_m.cols && v < depth_m.rows)) {
    return Visibility::kNotInView;
  }
  const float measured = depth_m.ptr<float>(static_cast<int>(v))[static_cast<int>(u)];
  if (!(measured > 0.f) || !std::isfinite(measured)) return Visibility::kNotInView;
  const double z = p_D.z();
  const double beyond_m = margin_m + truncation_m + truncation_per_m2 * z * z;
  return measured - z > beyond_m ? Visibility::kSeenFree : Visibility::kNotSeenFree;
}

}  // namespace mvod
