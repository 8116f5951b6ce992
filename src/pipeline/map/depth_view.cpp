#include "multiview_object_detection/pipeline/map/depth_view.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

namespace mvod {

bool DepthView::signedDistance(const Eigen::Vector3f& p_W, float* sdf_m) const {
  const Eigen::Vector3d p_D = T_D_W * p_W.cast<double>();
  if (!(p_D.z() > 0.0) || depth_m.empty() || depth_m.type() != CV_32FC1) return false;
  const double u = std::floor(K.fx * p_D.x() / p_D.z() + K.cx + 0.5);
  const double v = std::floor(K.fy * p_D.y() / p_D.z() + K.cy + 0.5);
  if (!(u >= 0.0 && v >= 0.0 && u < depth_m.cols && v < depth_m.rows)) return false;
  // A depth edge (a silhouette: a chair's leg before the wall) abstains: a voxel of the leg that
  // rounds to a pixel beside it would look seen through. The pixel and its 8 neighbours must all
  // have a depth, within the truncation of each other.
  const double z = p_D.z();
  const double truncation = truncation_m + truncation_per_m2 * z * z;
  const int u0 = static_cast<int>(u);
  const int v0 = static_cast<int>(v);
  if (lowest_3x3_m.size() == depth_m.size() && highest_3x3_m.size() == depth_m.size() &&
      lowest_3x3_m.type() == CV_32FC1 && highest_3x3_m.type() == CV_32FC1) {
    const float lowest = lowest_3x3_m.ptr<float>(v0)[u0];
    if (!(lowest > 0.f)) return false;
    if (highest_3x3_m.ptr<float>(v0)[u0] - lowest > truncation) return false;
    const double sdf = static_cast<double>(depth_m.ptr<float>(v0)[u0]) - z;
    if (sdf < -truncation) return false;
    *sdf_m = static_cast<float>(std::min(sdf, truncation));
    return true;
  }
  float lowest = std::numeric_limits<float>::infinity();
  float highest = 0.f;
  for (int dv = -1; dv <= 1; ++dv) {
    const int row = std::min(std::max(v0 + dv, 0), depth_m.rows - 1);
    const float* depths = depth_m.ptr<float>(row);
    for (int du = -1; du <= 1; ++du) {
      const float measured = depths[std::min(std::max(u0 + du, 0), depth_m.cols - 1)];
      if (!(measured > 0.f) || !std::isfinite(measured)) return false;
      lowest = std::min(lowest, measured);
      highest = std::max(highest, measured);
    }
  }
  if (highest - lowest > truncation) return false;
  const double sdf = static_cast<double>(depth_m.ptr<float>(v0)[u0]) - z;
  if (sdf < -truncation) return false;
  *sdf_m = static_cast<float>(std::min(sdf, truncation));
  return true;
}

namespace {

// 3 x 3 minimum and maximum of `valid` (invalid depths 0); the border replicated, as
// signedDistance clamps its pixels.
void neighbourhoodRanges(const cv::Mat& valid, cv::Mat* lowest, cv::Mat* highest) {
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3));
  cv::erode(valid, *lowest, kernel, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  cv::dilate(valid, *highest, kernel, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
}

}  // namespace

void DepthView::prepareNeighbourhoods() {
  lowest_3x3_m.release();
  highest_3x3_m.release();
  if (depth_m.empty() || depth_m.type() != CV_32FC1) return;
  // Invalid depths (0, negative, NaN, infinite) become 0: a neighbourhood's minimum is then 0
  // exactly where one of its pixels is invalid, and its maximum is that of the valid ones where
  // all are. min and max are exact, so the ranges are the floats of signedDistance's own loop.
  cv::Mat valid(depth_m.size(), CV_32FC1);
  for (int v = 0; v < depth_m.rows; ++v) {
    const float* in = depth_m.ptr<float>(v);
    float* out = valid.ptr<float>(v);
    for (int u = 0; u < depth_m.cols; ++u) {
      out[u] = in[u] > 0.f && in[u] <= std::numeric_limits<float>::max() ? in[u] : 0.f;
    }
  }
  neighbourhoodRanges(valid, &lowest_3x3_m, &highest_3x3_m);
}

DepthView::Visibility DepthView::visibility(const Eigen::Vector3f& p_W, double margin_m) const {
  const Eigen::Vector3d p_D = T_D_W * p_W.cast<double>();
  if (!(p_D.z() > 0.0) || depth_m.empty() || depth_m.type() != CV_32FC1) {
    return Visibility::kNotInView;
  }
  const double u = std::floor(K.fx * p_D.x() / p_D.z() + K.cx + 0.5);
  const double v = std::floor(K.fy * p_D.y() / p_D.z() + K.cy + 0.5);
  if (!(u >= 0.0 && v >= 0.0 && u < depth_m.cols && v < depth_m.rows)) {
    return Visibility::kNotInView;
  }
  const float measured = depth_m.ptr<float>(static_cast<int>(v))[static_cast<int>(u)];
  if (!(measured > 0.f) || !std::isfinite(measured)) return Visibility::kNotInView;
  const double z = p_D.z();
  const double truncation = truncation_m + truncation_per_m2 * z * z;
  if (measured - z > margin_m + truncation) return Visibility::kSeenFree;
  return measured - z < -truncation ? Visibility::kHidden : Visibility::kOnSurface;
}

std::shared_ptr<DepthView> makeDepthView(const cv::Mat& depth, const CameraIntrinsics& K_depth,
                                         const Eigen::Isometry3d& T_W_D, double min_valid_m,
                                         double max_valid_m, double truncation_m,
                                         double truncation_per_m2) {
  auto view = std::make_shared<DepthView>();
  // Metres, 0 where invalid (NaN, or outside the valid range: 0 and 65535 mm too).
  depth.convertTo(view->depth_m, CV_32FC1, depth.type() == CV_16UC1 ? 0.001 : 1.0);
  // Valid depths are finite and positive: the image is its own validity image, and its 3 x 3
  // ranges need no copy of it (a second pass over the image; the same values as
  // prepareNeighbourhoods). Every voxel of every object seen here is tested against them.
  const float min_m =
      std::max(static_cast<float>(min_valid_m), std::numeric_limits<float>::denorm_min());
  const float max_m = std::min(static_cast<float>(max_valid_m), std::numeric_limits<float>::max());
  for (int v = 0; v < view->depth_m.rows; ++v) {
    float* row = view->depth_m.ptr<float>(v);
    for (int u = 0; u < view->depth_m.cols; ++u) {
      row[u] = row[u] >= min_m && row[u] <= max_m ? row[u] : 0.f;
    }
  }
  if (view->depth_m.type() == CV_32FC1 && !view->depth_m.empty()) {
    neighbourhoodRanges(view->depth_m, &view->lowest_3x3_m, &view->highest_3x3_m);
  }
  view->K = K_depth;
  view->T_D_W = T_W_D.inverse();
  view->truncation_m = truncation_m;
  view->truncation_per_m2 = truncation_per_m2;
  return view;
}

}  // namespace mvod
