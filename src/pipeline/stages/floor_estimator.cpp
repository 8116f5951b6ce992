#include "multiview_object_detection/pipeline/stages/floor_estimator.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

namespace mvod {

Status FloorEstimator::Config::isValid() const {
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  auto non_negative = [](double v) { return std::isfinite(v) && v >= 0.0; };
  if (!positive(layer_thickness_m)) return Status::Error("layer_thickness_m must be > 0");
  if (!(min_layer_fraction > 0.0 && min_layer_fraction <= 1.0)) {
    return Status::Error("min_layer_fraction must be in (0, 1]");
  }
  if (min_layer_points < 1) return Status::Error("min_layer_points must be >= 1");
  if (!(max_below_fraction >= 0.0 && max_below_fraction < 1.0)) {
    return Status::Error("max_below_fraction must be in [0, 1)");
  }
  if (!non_negative(clearance_m) || !non_negative(clearance_per_m2) ||
      !non_negative(grounding_distance_m)) {
    return Status::Error("clearance_m, clearance_per_m2 and grounding_distance_m must be >= 0");
  }
  return Status::Ok();
}

std::string FloorEstimator::Config::print() const {
  std::ostringstream out;
  out << "enable: " << (enable ? "true" : "false") << "\n"
      << "layer_thickness_m: " << layer_thickness_m << "\n"
      << "min_layer_fraction: " << min_layer_fraction << "\n"
      << "min_layer_points: " << min_layer_points << "\n"
      << "max_below_fraction: " << max_below_fraction << "\n"
      << "clearance_m: " << clearance_m << "\n"
      << "clearance_per_m2: " << clearance_per_m2 << "\n"
      << "grounding_distance_m: " << grounding_distance_m << "\n";
  return out.str();
}

void FloorEstimator::reset() {
  has_floor_ = false;
  floor_height_m_ = 0.0;
  up_ = Eigen::Vector3d::Zero();
}

void FloorEstimator::setFloor(double height_m, const Eigen::Vector3d& up) {
  has_floor_ = std::isfinite(height_m);
  floor_height_m_ = height_m;
  up_ = up;
}

bool FloorEstimator::addFrame(const PointCloud& points_W, const GravityFrame& gravity,
                              double* layer_height_m) {
  constexpr double kCosOneDegree = 0.99984769515639;
  if (!up_.isZero() && up_.dot(gravity.up) < kCosOneDegree) reset();
  up_ = gravity.up;

  std::vector<double> heights;
  heights.reserve(points_W.size());
  for (const Eigen::Vector3f& p : points_W) {
    if (p.allFinite()) heights.push_back(gravity.up.dot(p.cast<double>()));
  }
  if (heights.empty()) return false;
  const size_t n = heights.size();
  const size_t needed = std::max<size_t>(static_cast<size_t>(config_.min_layer_points),
                                         static_cast<size_t>(config_.min_layer_fraction * n));
  const size_t max_below = static_cast<size_t>(config_.max_below_fraction * n);
  // The window below starts at one of the lowest max_below + 1 heights and reaches at most
  // layer_thickness_m above it: only the heights up to there need sorting (a prefix of the sorted
  // order, with a margin for rounding), not the whole view.
  size_t sorted_end = n;
  if (max_below + 1 < n) {
    std::nth_element(heights.begin(), heights.begin() + max_below, heights.end());
    const double reach_m = heights[max_below] + config_.layer_thickness_m + 1e-6;
    sorted_end = static_cast<size_t>(std::partition(heights.begin(), heights.end(),
                                                    [reach_m](double h) { return h <= reach_m; }) -
                                     heights.begin());
  }
  std::sort(heights.begin(), heights.begin() + sorted_end);
  // Slide a window of layer_thickness_m up from the lowest point: the first window that holds
  // enough points, with few below it, is the floor layer.
  size_t hi = 0;
  for (size_t lo = 0; lo <= max_below && lo < n; ++lo) {
    hi = std::max(hi, lo);
    while (hi < sorted_end && heights[hi] - heights[lo] <= config_.layer_thickness_m) ++hi;
    if (hi - lo < needed) continue;
    // The floor surface: the median of the layer (its noise is symmetric about the surface).
    const double height_m = heights[lo + (hi - lo) / 2];
    if (layer_height_m != nullptr) *layer_height_m = height_m;
    if (!has_floor_ || height_m < floor_height_m_) {
      floor_height_m_ = height_m;
      has_floor_ = true;
    }
    return true;
  }
  return false;
}

}  // namespace mvod
