// The observed surface of a synthetic scene, the ground truth of its datasets: the noise-free
// back-projected pixels of all frames within the sensor's range, one point per voxel.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>
#include <unordered_map>
#include <vector>

#include "multiview_object_detection/simulation/renderer.h"

namespace mvod {
namespace simulation {

// Voxel grid accumulating back-projected points: mean position and colour, majority label
// (Boyer-Moore vote).
class VoxelAccumulator {
 public:
  explicit VoxelAccumulator(double voxel_m) : inverse_(1.0 / voxel_m) {}
  void add(const Eigen::Vector3d& p, const cv::Vec3b& bgr, int label);
  struct Voxel {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    uint64_t bgr[3] = {0, 0, 0};
    uint32_t count = 0;
    int label = 0;
    int votes = 0;
  };
  const std::vector<Voxel>& voxels() const { return voxels_; }

 private:
  double inverse_;
  std::unordered_map<uint64_t, uint32_t> index_;
  std::vector<Voxel> voxels_;
};

// The world points of the in-range pixels of a frame, in the accumulator (label_image: the label
// per pixel; only labels >= min_label are added).
void accumulateFrame(const SyntheticSceneConfig& config, const CameraIntrinsics& K,
                     const Eigen::Isometry3d& T_W_C, const RenderOutput& render,
                     const cv::Mat& label_image, int min_label, VoxelAccumulator* grid);

// The world points of each object's in-range pixels of a frame (render.labels k + 1 ->
// (*surfaces)[k], no colour).
void accumulateObjectSurfaces(const SyntheticSceneConfig& config, const CameraIntrinsics& K,
                              const Eigen::Isometry3d& T_W_C, const RenderOutput& render,
                              std::vector<VoxelAccumulator>* surfaces);

}  // namespace simulation
}  // namespace mvod
