#include "multiview_object_detection/pipeline/types/map_limits.h"

#include <cmath>
#include <sstream>

namespace mvod {

Status checkCameraInMap(const Eigen::Isometry3d& T_W_C, const std::string& what) {
  const Eigen::Vector3d t = T_W_C.translation();
  if (t.allFinite() && t.cwiseAbs().maxCoeff() <= kCameraCoordinateLimitM) return Status::Ok();
  std::ostringstream text;
  text << what << " is at (" << t.x() << ", " << t.y() << ", " << t.z() << ") m: beyond +-"
       << kCameraCoordinateLimitM << " m from the world origin, where the map (+-"
       << kMapCoordinateLimitM << " m) could not hold what it sees";
  return Status::Error(text.str());
}

Status checkMapVoxelSize(double voxel_size_m, const std::string& name) {
  if (std::isfinite(voxel_size_m) && voxel_size_m >= kMinMapVoxelSizeM &&
      voxel_size_m <= kMapCoordinateLimitM) {
    return Status::Ok();
  }
  std::ostringstream text;
  text << name << " must be in [" << kMinMapVoxelSizeM << ", " << kMapCoordinateLimitM
       << "] m (got " << voxel_size_m << "): smaller voxels' keys would wrap within the map's +-"
       << kMapCoordinateLimitM << " m";
  return Status::Error(text.str());
}

}  // namespace mvod
