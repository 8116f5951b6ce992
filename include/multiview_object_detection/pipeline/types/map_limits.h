// How far from the world origin the map reaches: one set of constants for what the inputs may hold
// (camera poses, depth), for what the map's voxel keys can address without wrapping, and for what
// a map file may hold (json_io refuses a file beyond it), so that whatever the map accepts it can
// save and load again.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {

// Every position a map file holds (box centres, points, keyframe poses) and every size lies within
// +-kMapCoordinateLimitM on each axis. Ten kilometres across: any building.
constexpr double kMapCoordinateLimitM = 5000.0;
// The farthest depth the extraction accepts (ObjectCloudExtractor::max_valid_depth_m): RGB-D
// sensors reach 4-10 m; stereo and ToF cameras a few tens.
constexpr double kMaxSensorRangeM = 50.0;
// Camera poses within this of the origin: their points (at most kMaxSensorRangeM away) and the
// boxes fitted to them, grown by at most their own extent, stay inside kMapCoordinateLimitM.
constexpr double kCameraCoordinateLimitM = kMapCoordinateLimitM - 2.0 * kMaxSensorRangeM;
// Voxel keys (pipeline/utils/voxel_key.h) hold cells in [-2^20, 2^20) per axis: a voxel at least
// this big addresses the whole map without wrapping (5000 m / 5 mm = 1e6 < 2^20 = 1048576).
constexpr double kMinMapVoxelSizeM = 0.005;
constexpr std::int64_t kVoxelKeyCellsPerSide = std::int64_t{1} << 20;
static_assert(kMapCoordinateLimitM / kMinMapVoxelSizeM + 1.0 < kVoxelKeyCellsPerSide,
              "voxel keys of the smallest voxel must cover the map");
static_assert(kCameraCoordinateLimitM > 0.0, "the camera range must be positive");
static_assert(kCameraCoordinateLimitM + 2.0 * kMaxSensorRangeM <= kMapCoordinateLimitM,
              "what a camera sees, and boxes grown from it, must fit in the map");

// Ok, or why the camera at T_W_C cannot be mapped (`what` names the pose): its translation is
// beyond kCameraCoordinateLimitM.
Status checkCameraInMap(const Eigen::Isometry3d& T_W_C, const std::string& what);

}  // namespace mvod
