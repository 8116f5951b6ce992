// Evidence fusion's per-voxel counts (VoxelEvidence) and the map that holds them per object
// (EvidenceMap): flat storage, so that a keyframe's pass over every voxel of an object (its signed
// distances, the supported voxels) reads one array instead of chasing hash-table nodes.
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "multiview_object_detection/pipeline/utils/flat_hash_map.h"

namespace mvod {

// Evidence fusion: how often a voxel of the object's grid was inside a view's cut, and how often a
// view saw surface there but left it out of its cut.
// normal_sum adds the cut's normals in the voxel (each turned towards its camera), so that the
// fused box's Manhattan yaw comes from the voxels' normals without a neighbour search over the
// object.
// sdf_sum / sdf_count: the mean truncated projective signed distance of the views that saw the
// voxel (DepthView): near 0 on the surface the views measured, larger in front of it where one
// noisy view left a voxel that the others saw through.
struct VoxelEvidence {
  std::uint16_t inside = 0;
  std::uint16_t outside = 0;
  Eigen::Vector3f normal_sum = Eigen::Vector3f::Zero();
  std::uint16_t sdf_count = 0;
  float sdf_sum = 0.f;
};

// Voxel key (voxelKeyOf / packVoxel) -> VoxelEvidence, in insertion order (FlatHashMap).
using EvidenceMap = FlatHashMap<std::int64_t, VoxelEvidence>;

}  // namespace mvod
