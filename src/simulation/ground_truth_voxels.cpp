#include "multiview_object_detection/simulation/ground_truth_voxels.h"

#include <cmath>

#include "multiview_object_detection/simulation/depth_sensor_model.h"

namespace mvod {
namespace simulation {

void VoxelAccumulator::add(const Eigen::Vector3d& p, const cv::Vec3b& bgr, int label) {
  const int64_t ix = static_cast<int64_t>(std::floor(p.x() * inverse_)) + (1 << 20);
  const int64_t iy = static_cast<int64_t>(std::floor(p.y() * inverse_)) + (1 << 20);
  const int64_t iz = static_cast<int64_t>(std::floor(p.z() * inverse_)) + (1 << 20);
  const uint64_t key = (static_cast<uint64_t>(ix) << 42) | (static_cast<uint64_t>(iy) << 21) |
                       static_cast<uint64_t>(iz);
  const auto inserted = index_.emplace(key, static_cast<uint32_t>(voxels_.size()));
  if (inserted.second) voxels_.emplace_back();
  Voxel& voxel = voxels_[inserted.first->second];
  voxel.sum += p;
  for (int c = 0; c < 3; ++c) voxel.bgr[c] += bgr[c];
  ++voxel.count;
  if (voxel.votes == 0) {
    voxel.label = label;
    voxel.votes = 1;
  } else {
    voxel.votes += voxel.label == label ? 1 : -1;
  }
}

void accumulateFrame(const SyntheticSceneConfig& config, const CameraIntrinsics& K,
                     const Eigen::Isometry3d& T_W_C, const RenderOutput& render,
                     const cv::Mat& label_image, int min_label, VoxelAccumulator* grid) {
  const Eigen::Matrix3d R = T_W_C.linear();
  const Eigen::Vector3d t = T_W_C.translation();
  for (int v = 0; v < render.z_m.rows; ++v) {
    const float* z_row = render.z_m.ptr<float>(v);
    const float* cos_row = render.cos_incidence.ptr<float>(v);
    const int32_t* label_row = label_image.ptr<int32_t>(v);
    const cv::Vec3b* color_row = render.color.ptr<cv::Vec3b>(v);
    for (int u = 0; u < render.z_m.cols; ++u) {
      if (label_row[u] < min_label || !inSensorRange(config, z_row[u], cos_row[u])) continue;
      const double z = z_row[u];
      const Eigen::Vector3d p_C((u - K.cx) * z / K.fx, (v - K.cy) * z / K.fy, z);
      grid->add(R * p_C + t, color_row[u], label_row[u]);
    }
  }
}

void accumulateObjectSurfaces(const SyntheticSceneConfig& config, const CameraIntrinsics& K,
                              const Eigen::Isometry3d& T_W_C, const RenderOutput& render,
                              std::vector<VoxelAccumulator>* surfaces) {
  const cv::Mat& labels = render.labels;
  const Eigen::Matrix3d R = T_W_C.linear();
  const Eigen::Vector3d t = T_W_C.translation();
  for (int v = 0; v < K.height; ++v) {
    for (int u = 0; u < K.width; ++u) {
      const int label = labels.at<int32_t>(v, u);
      const float z = render.z_m.at<float>(v, u);
      if (label < 1 || !inSensorRange(config, z, render.cos_incidence.at<float>(v, u))) continue;
      const Eigen::Vector3d p_C((u - K.cx) * z / K.fx, (v - K.cy) * z / K.fy, z);
      (*surfaces)[label - 1].add(R * p_C + t, cv::Vec3b(), label);
    }
  }
}

}  // namespace simulation
}  // namespace mvod
