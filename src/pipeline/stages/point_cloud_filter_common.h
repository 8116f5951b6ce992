// Shared by the point cloud filter's files (point_cloud_filter, _voxelize, _outliers): not a public
// header.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {
namespace point_cloud_filter_detail {

// |coordinate / leaf| beyond this cannot be stored in a 64-bit voxel index.
constexpr double kMaxVoxelIndex = 4.0e18;

inline PointCloud finitePoints(const PointCloud& points) {
  PointCloud out;
  out.reserve(points.size());
  for (const Eigen::Vector3f& p : points) {
    if (p.allFinite()) out.push_back(p);
  }
  return out;
}

// How the statistical outlier removal's variance is summed. Its two callers must keep their bits
// (the maps stay as they were), and these differ in two ways: kPcl is PCL's
// StatisticalOutlierRemoval exactly (each float distance squared in float; a variance that rounds
// below zero is let through, its root NaN, and nothing is removed), which the exact grid search
// reproduces; kDoubleClamped (the voxel-centre statistic) squares in double and clamps the
// variance at zero.
enum class VarianceSum { kPcl, kDoubleClamped };

// PCL's rule: a point goes when its mean distance to its k nearest lies beyond mean +
// stddev_mul x standard deviation of those mean distances over the cloud. Returns the points of
// `finite` (one distance each) that stay, in order.
inline PointCloud keepBelowStatisticalThreshold(const PointCloud& finite,
                                                const std::vector<float>& mean_distance_m,
                                                double stddev_mul, VarianceSum rule) {
  double sum = 0.0;
  double sq_sum = 0.0;
  for (const float distance : mean_distance_m) {
    sum += distance;
    sq_sum +=
        rule == VarianceSum::kPcl ? distance * distance : static_cast<double>(distance) * distance;
  }
  const double count_d = static_cast<double>(mean_distance_m.size());
  const double mean = sum / count_d;
  double variance = (sq_sum - sum * sum / count_d) / (count_d - 1.0);
  if (rule == VarianceSum::kDoubleClamped) variance = std::max(0.0, variance);
  const double threshold = mean + stddev_mul * std::sqrt(variance);
  PointCloud out;
  out.reserve(finite.size());
  for (std::size_t i = 0; i < finite.size(); ++i) {
    if (!(mean_distance_m[i] > threshold)) out.push_back(finite[i]);
  }
  return out;
}

}  // namespace point_cloud_filter_detail
}  // namespace mvod
