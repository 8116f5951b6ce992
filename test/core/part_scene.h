// A ray-cast world of axis-aligned parts over a floor (z up, floor z = 0) for core tests: a table
// with a chair pushed under it and the like. Shared by the support-surface and amodal completion
// tests.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/class_priors.h"
#include "multiview_object_detection/pipeline/types/detection.h"
#include "multiview_object_detection/pipeline/types/rgbd_frame.h"

namespace mvod {
namespace test {

struct Part {
  std::string object;  // which object it belongs to ("" = background)
  Eigen::Vector3d min_m;
  Eigen::Vector3d max_m;  // axis-aligned, world z up, floor z = 0
};

// Ray-casts axis-aligned parts over a floor; the label image names the object of each pixel.
struct PartScene {
  std::vector<Part> parts;

  double cast(const Eigen::Vector3d& o, const Eigen::Vector3d& d, int* part) const {
    double best = d.z() < -1e-9 ? -o.z() / d.z() : std::numeric_limits<double>::infinity();
    *part = -1;
    for (size_t k = 0; k < parts.size(); ++k) {
      double t_near = -std::numeric_limits<double>::infinity();
      double t_far = std::numeric_limits<double>::infinity();
      bool miss = false;
      for (int i = 0; i < 3 && !miss; ++i) {
        if (std::abs(d[i]) < 1e-12) {
          miss = o[i] < parts[k].min_m[i] || o[i] > parts[k].max_m[i];
          continue;
        }
        double t1 = (parts[k].min_m[i] - o[i]) / d[i];
        double t2 = (parts[k].max_m[i] - o[i]) / d[i];
        if (t1 > t2) std::swap(t1, t2);
        t_near = std::max(t_near, t1);
        t_far = std::min(t_far, t2);
      }
      if (!miss && t_near <= t_far && t_near > 0.0 && t_near < best) {
        best = t_near;
        *part = static_cast<int>(k);
      }
    }
    return best;
  }

  // A 640x480 frame and the 2D box of `object`'s pixels (and, when asked, their mask).
  RgbdFrame render(const Eigen::Isometry3d& T_W_D, const std::string& object, cv::Rect* box,
                   cv::Mat* object_mask = nullptr) const {
    RgbdFrame frame;
    frame.name = "frame-0";
    frame.K_depth = CameraIntrinsics{520.0, 520.0, 319.5, 239.5, 640, 480};
    frame.K_color = frame.K_depth;
    frame.registered = true;
    frame.T_W_D = T_W_D;
    frame.depth = cv::Mat(480, 640, CV_16UC1, cv::Scalar(0));
    frame.color_bgr = cv::Mat(480, 640, CV_8UC3, cv::Scalar(90, 120, 150));
    cv::Mat mask(480, 640, CV_8UC1, cv::Scalar(0));
    for (int v = 0; v < 480; ++v) {
      for (int u = 0; u < 640; ++u) {
        const Eigen::Vector3d ray((u - 319.5) / 520.0, (v - 239.5) / 520.0, 1.0);
        int part = -1;
        const double t = cast(T_W_D.translation(), T_W_D.linear() * ray, &part);
        if (!std::isfinite(t) || t > 8.0) continue;
        frame.depth.at<uint16_t>(v, u) = static_cast<uint16_t>(std::lround(t * 1000.0));
        if (part >= 0 && parts[part].object == object) mask.at<uint8_t>(v, u) = 255;
      }
    }
    *box = cv::boundingRect(mask);
    if (object_mask != nullptr) *object_mask = mask;
    return frame;
  }
};

// Optical frame at `position` looking at `target`, world z up.
inline Eigen::Isometry3d lookAt(const Eigen::Vector3d& position, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - position).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = z.cross(x);
  T.linear().col(2) = z;
  T.translation() = position;
  return T;
}

// A box detector's detection (FastestDet, YOLO): its mask is the filled box, the detectors'
// contract for detections without masks.
inline Detection2D boxOnlyDetection(const std::string& class_name, const cv::Rect& box_px,
                                    const cv::Size& image_size, float score = 0.9f) {
  Detection2D detection;
  detection.class_name = class_name;
  detection.class_id = cocoClassId(class_name);
  detection.score = score;
  detection.box_px = box_px;
  detection.mask = cv::Mat::zeros(image_size, CV_8UC1);
  cv::rectangle(detection.mask, box_px, cv::Scalar(255), cv::FILLED);
  return detection;
}

}  // namespace test
}  // namespace mvod
