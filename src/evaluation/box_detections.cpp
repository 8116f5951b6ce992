#include "multiview_object_detection/evaluation/box_detections.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "multiview_object_detection/pipeline/types/class_priors.h"

namespace mvod {

std::vector<Detection2D> boxDetectionsFromGroundTruth(const std::vector<GroundTruthObject>& truth,
                                                      const RgbdFrame& frame,
                                                      const BoxDetectionOptions& options) {
  std::vector<Detection2D> detections;
  const CameraIntrinsics& K = frame.K_color;
  const cv::Size size = frame.color_bgr.size();
  if (!K.isValid() || size.area() == 0) return detections;
  const Eigen::Isometry3d T_C_W = frame.T_C_D * frame.T_W_D.inverse();
  auto project = [&K](const Eigen::Vector3d& p_C) {
    return Eigen::Vector2d(K.fx * p_C.x() / p_C.z() + K.cx, K.fy * p_C.y() / p_C.z() + K.cy);
  };
  for (const GroundTruthObject& object : truth) {
    const Eigen::Vector3d centre_C = T_C_W * object.box.center_m;
    if (!(centre_C.z() > options.min_depth_m)) continue;
    const Eigen::Vector2d centre_px = project(centre_C);
    if (!(centre_px.x() >= 0 && centre_px.y() >= 0 && centre_px.x() < size.width &&
          centre_px.y() < size.height)) {
      continue;
    }
    Eigen::Vector2d lower = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector2d upper = -lower;
    bool in_front = true;
    for (int i = 0; i < 8; ++i) {
      const Eigen::Vector3d sign((i & 1) ? 0.5 : -0.5, (i & 2) ? 0.5 : -0.5, (i & 4) ? 0.5 : -0.5);
      const Eigen::Vector3d corner_C =
          T_C_W *
          (object.box.center_m + object.box.rotation * sign.cwiseProduct(object.box.size_m));
      if (!(corner_C.z() > options.min_depth_m)) {
        in_front = false;
        break;
      }
      const Eigen::Vector2d px = project(corner_C);
      lower = lower.cwiseMin(px);
      upper = upper.cwiseMax(px);
    }
    if (!in_front) continue;
    const double full_area = (upper - lower).prod();
    const double x1 = std::max(0.0, std::floor(lower.x()));
    const double y1 = std::max(0.0, std::floor(lower.y()));
    const double x2 = std::min<double>(size.width, std::ceil(upper.x()));
    const double y2 = std::min<double>(size.height, std::ceil(upper.y()));
    if (x2 - x1 < options.min_side_px || y2 - y1 < options.min_side_px) continue;
    if ((x2 - x1) * (y2 - y1) < options.min_inside_fraction * full_area) continue;
    Detection2D detection;
    detection.class_name = object.class_name;
    detection.class_id = cocoClassId(object.class_name);
    detection.score = options.score;
    detection.box_px = cv::Rect(static_cast<int>(x1), static_cast<int>(y1),
                                static_cast<int>(x2 - x1), static_cast<int>(y2 - y1));
    detection.mask = cv::Mat::zeros(size, CV_8UC1);
    detection.mask(detection.box_px).setTo(255);
    detections.push_back(std::move(detection));
  }
  return detections;
}

std::string boxDetectionsToJson(const std::vector<Detection2D>& detections) {
  nlohmann::json list = nlohmann::json::array();
  for (const Detection2D& d : detections) {
    list.push_back({{"class_name", d.class_name},
                    {"score", d.score},
                    {"box", {d.box_px.x, d.box_px.y, d.box_px.br().x, d.box_px.br().y}}});
  }
  return list.dump() + "\n";
}

}  // namespace mvod
