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

}  // namespace mvod
