#include "multiview_object_detection/evaluation/registration_check.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace mvod {
namespace {

// Depth in metres, NaN where invalid (0, or 65535 on Kinect-style sensors).
float registrationDepthM(const cv::Mat& depth, int v, int u) {
  if (depth.type() == CV_16UC1) {
    const uint16_t mm = depth.at<uint16_t>(v, u);
    return mm == 0 || mm == 65535 ? std::numeric_limits<float>::quiet_NaN() : mm * 1e-3f;
  }
  const float z = depth.at<float>(v, u);
  return z > 0.f && std::isfinite(z) ? z : std::numeric_limits<float>::quiet_NaN();
}

// The near side of each depth jump, as colour pixel coordinates (not rounded).
std::vector<cv::Point2d> projectedDepthEdges(const RgbdFrame& frame, double jump_m) {
  std::vector<cv::Point2d> edges;
  const cv::Mat& depth = frame.depth;
  const auto addIfNear = [&](int v, int u, float z, float other) {
    if (!(std::abs(z - other) > jump_m) || !(z < other)) return;  // NaN compares false
    const Eigen::Vector3d p_D((u - frame.K_depth.cx) * z / frame.K_depth.fx,
                              (v - frame.K_depth.cy) * z / frame.K_depth.fy, z);
    const Eigen::Vector3d p_C = frame.T_C_D * p_D;
    if (!(p_C.z() > 0.0)) return;
    edges.emplace_back(frame.K_color.fx * p_C.x() / p_C.z() + frame.K_color.cx,
                       frame.K_color.fy * p_C.y() / p_C.z() + frame.K_color.cy);
  };
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) {
      const float z = registrationDepthM(depth, v, u);
      if (std::isnan(z)) continue;
      // A far neighbour that is invalid is no edge: only jumps between two measured depths.
      if (u + 1 < depth.cols) addIfNear(v, u, z, registrationDepthM(depth, v, u + 1));
      if (u > 0) addIfNear(v, u, z, registrationDepthM(depth, v, u - 1));
      if (v + 1 < depth.rows) addIfNear(v, u, z, registrationDepthM(depth, v + 1, u));
      if (v > 0) addIfNear(v, u, z, registrationDepthM(depth, v - 1, u));
    }
  }
  return edges;
}

}  // namespace

RegistrationShift measureRegistrationShift(const RgbdFrame& frame,
                                           const RegistrationCheckConfig& config) {
  RegistrationShift result;
  if (frame.color_bgr.empty() || frame.depth.empty() ||
      (frame.depth.type() != CV_16UC1 && frame.depth.type() != CV_32FC1)) {
    return result;
  }
  cv::Mat gray;
  cv::cvtColor(frame.color_bgr, gray, cv::COLOR_BGR2GRAY);
  cv::GaussianBlur(gray, gray, cv::Size(5, 5), 1.2);
  cv::Mat colour_edges;
  cv::Canny(gray, colour_edges, config.canny_low, config.canny_high);
  cv::Mat distance_px;  // to the nearest colour edge
  cv::distanceTransform(255 - colour_edges, distance_px, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  const std::vector<cv::Point2d> edges = projectedDepthEdges(frame, config.depth_jump_m);
  double best = std::numeric_limits<double>::infinity();
  for (int du = -config.max_shift_px; du <= config.max_shift_px; ++du) {
    for (int dv = -config.max_shift_px; dv <= config.max_shift_px; ++dv) {
      double sum = 0.0;
      int count = 0;
      for (const cv::Point2d& p : edges) {
        const int u = static_cast<int>(std::floor(p.x + 0.5)) + du;
        const int v = static_cast<int>(std::floor(p.y + 0.5)) + dv;
        if (u < 0 || v < 0 || u >= distance_px.cols || v >= distance_px.rows) continue;
        sum += std::min<double>(distance_px.at<float>(v, u), config.truncate_px);
        ++count;
      }
      if (count < config.min_edge_points) continue;
      const double mean = sum / count;
      if (mean < best) {
        best = mean;
        result = {true, du, dv, mean, count};
      }
    }
  }
  return result;
}

}  // namespace mvod
