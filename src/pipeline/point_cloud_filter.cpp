#include "multiview_object_detection/pipeline/point_cloud_filter.h"

#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <numeric>
#include <sstream>

namespace mvod {
namespace {

// |coordinate / leaf| beyond this cannot be stored in a 64-bit voxel index.
constexpr double kMaxVoxelIndex = 4.0e18;

PointCloud finitePoints(const PointCloud& points) {
  PointCloud out;
  out.reserve(points.size());
  for (const Eigen::Vector3f& p : points) {
    if (p.allFinite()) out.push_back(p);
  }
  return out;
}

}  // namespace

Status PointCloudFilter::Config::isValid() const {
  if (!(std::isfinite(voxel_leaf_size_m) && voxel_leaf_size_m > 0.0)) {
    return Status::Error("voxel_leaf_size_m must be a finite value > 0 (got " +
                         std::to_string(voxel_leaf_size_m) + ")");
  }
  if (!(std::isfinite(min_depth_m) && min_depth_m >= 0.0)) {
    return Status::Error("min_depth_m must be a finite value >= 0 (got " +
                         std::to_string(min_depth_m) + ")");
  }
  if (!(std::isfinite(max_depth_m) && max_depth_m > min_depth_m)) {
    return Status::Error("max_depth_m must be finite and > min_depth_m (got " +
                         std::to_string(max_depth_m) + ")");
  }
  if (sor_mean_k < 1) {
    return Status::Error("sor_mean_k must be >= 1 (got " + std::to_string(sor_mean_k) + ")");
  }
  if (!(std::isfinite(sor_stddev_mul) && sor_stddev_mul > 0.0)) {
    return Status::Error("sor_stddev_mul must be a finite value > 0 (got " +
                         std::to_string(sor_stddev_mul) + ")");
  }
  return Status::Ok();
}

std::string PointCloudFilter::Config::print() const {
  std::ostringstream out;
  out << "enable: " << (enable ? "true" : "false") << "\n"
      << "voxel_leaf_size_m: " << voxel_leaf_size_m << "\n"
      << "min_depth_m: " << min_depth_m << "\n"
      << "max_depth_m: " << max_depth_m << "\n"
      << "sor_mean_k: " << sor_mean_k << "\n"
      << "sor_stddev_mul: " << sor_stddev_mul << "\n";
  return out.str();
}

PointCloud PointCloudFilter::filterCameraFrame(const PointCloud& points_C) const {
  if (!config_.enable) return points_C;
  // Sec. 3.2: depth range first (cheap, removes the noisiest far points), then the 0.01 m grid,
  // then outliers on the uniform-density cloud.
  const PointCloud in_range = passThroughDepth(points_C, config_.min_depth_m, config_.max_depth_m);
  const PointCloud voxelized = voxelize(in_range, config_.voxel_leaf_size_m);
  return removeStatisticalOutliers(voxelized, config_.sor_mean_k, config_.sor_stddev_mul);
}

PointCloud PointCloudFilter::filterFused(const PointCloud& points_W, double on_grid_m) const {
  if (!config_.enable) return points_W;
  // No pass-through: the fused cloud (Eq. 7) is in the world frame, depth means nothing there.
  if (on_grid_m == config_.voxel_leaf_size_m) {
    return removeStatisticalOutliers(points_W, config_.sor_mean_k, config_.sor_stddev_mul);
  }
  const PointCloud voxelized = voxelize(points_W, config_.voxel_leaf_size_m);
  return removeStatisticalOutliers(voxelized, config_.sor_mean_k, config_.sor_stddev_mul);
}

PointCloud PointCloudFilter::voxelize(const PointCloud& points, double leaf_size_m) {
  if (!(std::isfinite(leaf_size_m) && leaf_size_m > 0.0)) return finitePoints(points);

  // 64-bit integer voxel index per point; sorting by it gives a deterministic output order and
  // groups each voxel's points, without PCL's 32-bit index limit for large extents.
  using Key = std::array<std::int64_t, 3>;
  std::vector<std::pair<Key, std::size_t>> keyed;
  keyed.reserve(points.size());
  const double inv_leaf = 1.0 / leaf_size_m;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f& p = points[i];
    if (!p.allFinite()) continue;
    Key key;
    bool representable = true;
    for (int d = 0; d < 3; ++d) {
      const double index = std::floor(static_cast<double>(p[d]) * inv_leaf);
      if (!(std::abs(index) < kMaxVoxelIndex)) {
        representable = false;
        break;
      }
      key[d] = static_cast<std::int64_t>(index);
    }
    if (representable) keyed.emplace_back(key, i);
  }
  std::sort(keyed.begin(), keyed.end());

  PointCloud out;
  std::size_t begin = 0;
  while (begin < keyed.size()) {
    std::size_t end = begin;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    while (end < keyed.size() && keyed[end].first == keyed[begin].first) {
      sum += points[keyed[end].second].cast<double>();
      ++end;
    }
    out.emplace_back((sum / static_cast<double>(end - begin)).cast<float>());
    begin = end;
  }
  return out;
}

PointCloud PointCloudFilter::passThroughDepth(const PointCloud& points_C, double min_depth_m,
                                              double max_depth_m) {
  PointCloud out;
  out.reserve(points_C.size());
  for (const Eigen::Vector3f& p : points_C) {
    if (p.allFinite() && p.z() >= min_depth_m && p.z() <= max_depth_m) out.push_back(p);
  }
  return out;
}

PointCloud PointCloudFilter::removeStatisticalOutliers(const PointCloud& points, int mean_k,
                                                       double stddev_mul) {
  PointCloud finite = finitePoints(points);
  if (mean_k < 1 || !std::isfinite(stddev_mul) ||
      finite.size() < static_cast<std::size_t>(mean_k) + 1) {
    return finite;
  }

  // PCL's StatisticalOutlierRemoval: mean distance to the k nearest neighbours per point; drop
  // points whose mean lies beyond mean + stddev_mul * stddev over all points.
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->resize(finite.size());
  for (std::size_t i = 0; i < finite.size(); ++i) {
    (*cloud)[i] = pcl::PointXYZ(finite[i].x(), finite[i].y(), finite[i].z());
  }
  pcl::StatisticalOutlierRemoval<pcl::PointXYZ> sor;
  sor.setInputCloud(cloud);
  sor.setMeanK(mean_k);
  sor.setStddevMulThresh(stddev_mul);
  pcl::Indices kept;
  sor.filter(kept);

  PointCloud out;
  out.reserve(kept.size());
  for (const auto index : kept) out.push_back(finite[static_cast<std::size_t>(index)]);
  return out;
}

}  // namespace mvod
