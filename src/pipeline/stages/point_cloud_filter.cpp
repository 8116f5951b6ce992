#include "multiview_object_detection/pipeline/stages/point_cloud_filter.h"

#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <numeric>
#include <sstream>
#include <unordered_set>

#include "multiview_object_detection/pipeline/types/parameter_ranges.h"
#include "multiview_object_detection/pipeline/utils/parallel.h"
#include "point_cloud_filter_common.h"

namespace mvod {

using point_cloud_filter_detail::finitePoints;

Status PointCloudFilter::Config::isValid() const {
  if (Status s = checkParameterRange("filter/voxel_leaf_size_m", voxel_leaf_size_m); !s) return s;
  if (!(std::isfinite(min_depth_m) && min_depth_m >= 0.0)) {
    return Status::Error("min_depth_m must be a finite value >= 0 (got " +
                         std::to_string(min_depth_m) + ")");
  }
  if (!(std::isfinite(max_depth_m) && max_depth_m > min_depth_m)) {
    return Status::Error("max_depth_m must be finite and > min_depth_m (got " +
                         std::to_string(max_depth_m) + ")");
  }
  if (num_threads < 1 || num_threads > 256) {
    return Status::Error("num_threads must be in [1, 256] (got " + std::to_string(num_threads) +
                         ")");
  }
  if (outlier_removal != "voxel_neighbours" && outlier_removal != "statistical" &&
      outlier_removal != "statistical_centres" && outlier_removal != "none") {
    return Status::Error("outlier_removal must be voxel_neighbours, statistical or none (got '" +
                         outlier_removal + "')");
  }
  if (Status s = checkParameterRange("filter/min_voxel_neighbours", min_voxel_neighbours); !s)
    return s;
  if (Status s = checkParameterRange("filter/sor_mean_k", sor_mean_k); !s) return s;
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
      << "outlier_removal: " << outlier_removal << "\n"
      << "min_voxel_neighbours: " << min_voxel_neighbours << "\n"
      << "sor_mean_k: " << sor_mean_k << "\n"
      << "sor_stddev_mul: " << sor_stddev_mul << "\n";
  return out.str();
}

PointCloud PointCloudFilter::filterCameraFrame(const PointCloud& points_C) const {
  if (!config_.enable) return points_C;
  // Sec. 3.2: depth range first (cheap, removes the noisiest far points), then the 0.01 m grid,
  // then outliers on the uniform-density cloud.
  return filterPassedThrough(passThroughDepth(points_C, config_.min_depth_m, config_.max_depth_m));
}

PointCloud PointCloudFilter::filterPassedThrough(const PointCloud& in_range_C) const {
  if (!config_.enable) return in_range_C;
  return removeOutliers(voxelize(in_range_C, config_.voxel_leaf_size_m));
}

PointCloud PointCloudFilter::removeOutliers(const PointCloud& voxelized) const {
  if (config_.outlier_removal == "voxel_neighbours") {
    return removeSparseVoxels(voxelized, config_.voxel_leaf_size_m, config_.min_voxel_neighbours);
  }
  if (config_.outlier_removal == "statistical_centres") {
    return removeStatisticalOutliersOnVoxelCentres(voxelized, config_.sor_mean_k,
                                                   config_.sor_stddev_mul,
                                                   config_.voxel_leaf_size_m, config_.num_threads);
  }
  if (config_.outlier_removal == "statistical") {
    return removeStatisticalOutliersOnGrid(voxelized, config_.sor_mean_k, config_.sor_stddev_mul,
                                           config_.voxel_leaf_size_m, config_.num_threads);
  }
  return voxelized;
}

PointCloud PointCloudFilter::filterFused(const PointCloud& points_W, double on_grid_m) const {
  if (!config_.enable) return points_W;
  // No pass-through: the fused cloud (Eq. 7) is in the world frame, depth means nothing there.
  // A cloud already on this grid is not voxelised again.
  if (on_grid_m == config_.voxel_leaf_size_m) return removeOutliers(points_W);
  return removeOutliers(voxelize(points_W, config_.voxel_leaf_size_m));
}

PointCloud PointCloudFilter::passThroughDepth(const PointCloud& points_C, double min_depth_m,
                                              double max_depth_m) {
  PointCloud out;
  out.reserve(points_C.size());
  for (const Eigen::Vector3f& p : points_C) {
    if (inDepthRange(p, min_depth_m, max_depth_m)) out.push_back(p);
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
