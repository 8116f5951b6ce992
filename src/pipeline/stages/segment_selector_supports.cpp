// SegmentSelector, what the object stands, lies or hangs on: the surfaces that a class resting on
// the floor stands beside (markResting), the support a flat object lies or hangs on
// (chooseFlatSupport), the support around what stands on a table (findSupport, onSupport) and a
// flat-topped object's top (findFlatTop, belowFlatTop). The other phases: segment_selector.cpp.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <map>
#include <opencv2/imgproc.hpp>
#include <utility>
#include <vector>

#include "multiview_object_detection/pipeline/stages/segment_selector.h"
#include "segment_selector_geometry.h"
#include "segment_selector_work.h"

namespace mvod {
namespace {

// The share of a detection's ring that the support around it holds: the ring of a cup on a table
// is mostly table top, while a wall, a shelf of books or a cluttered background spreads over many
// heights. From 0.2 to 0.4 the AP and per-object IoUs of the redkitchen with YOLOv5n-seg, of make
// demo's room and of the synthetic rooms were the same; at 0.1 the synthetic rooms' books lost
// (segmentation AP 3.3 -> 3.1), at 0.5 make demo's book (IoU 0.67 -> 0.24).
constexpr double kSupportMinRingShare = 0.3;

}  // namespace

using segment_selector_geometry::densestBand;

bool SegmentSelector::findSupport(const Work& work, float lowest_m, float highest_m,
                                  float* support_m) const {
  // What stands on a table is seen with the table around it: the support is the horizontal
  // surface that runs from the ring into the kept set, the band of 2 plane_distance_m of heights,
  // from the kept set's lowest point up, that holds the most of the ring's points (at least
  // kSupportMinRingShare of them: not the floor beyond the table, nor a wall behind it).
  if (work.ring_heights_m.empty()) return false;
  const float band_m = static_cast<float>(config_.plane_distance_m);
  const std::size_t on_band =
      densestBand(work.ring_heights_m, 2.f * band_m, lowest_m - band_m, highest_m, support_m);
  return on_band > 0 && static_cast<double>(on_band) >=
                            kSupportMinRingShare * static_cast<double>(work.ring_heights_m.size());
}

std::vector<char> SegmentSelector::onSupport(const Work& work) const {
  // The kept points within plane_distance_m above the support (or below it) and outside the
  // footprint of what stands above that are the support's, which an imprecise mask, or one LCCP
  // segment with the object, brought in. The footprint keeps the object's lowest points.
  std::vector<char> on_support;
  if (work.ring_heights_m.empty()) return on_support;
  std::vector<std::pair<int, float>> kept_heights_m;  // (point, height along up)
  float lowest_m = std::numeric_limits<float>::infinity();
  float highest_m = -lowest_m;
  for (int s = 0; s < work.num_segments; ++s) {
    if (!work.kept[s]) continue;
    for (const int i : work.segments[s]) {
      const float height_m = work.up.dot(work.points_W[i]);
      kept_heights_m.emplace_back(i, height_m);
      lowest_m = std::min(lowest_m, height_m);
      highest_m = std::max(highest_m, height_m);
    }
  }
  float support_m = 0.f;
  if (!findSupport(work, lowest_m, highest_m, &support_m)) return on_support;
  const float limit_m = support_m + static_cast<float>(config_.plane_distance_m);
  const auto footprint = [&work](int i) {
    return cv::Point2f(work.x_h.dot(work.points_W[i]), work.y_h.dot(work.points_W[i]));
  };
  std::vector<cv::Point2f> standing;
  for (const auto& point : kept_heights_m) {
    if (point.second > limit_m) standing.push_back(footprint(point.first));
  }
  // Nothing stands on it (a magazine within the band): the kept set as it is.
  if (standing.size() < kMinStandingPoints) return on_support;
  std::vector<cv::Point2f> hull;
  cv::convexHull(standing, hull);
  on_support.assign(work.points.size(), 0);
  for (const auto& point : kept_heights_m) {
    if (point.second > limit_m) continue;
    on_support[point.first] = cv::pointPolygonTest(hull, footprint(point.first), false) < 0;
  }
  return on_support;
}

void SegmentSelector::markResting(Work* work, Result* result) const {
  // on_floor classes: what rests on a horizontal bounding surface (a table top running past the
  // detection) is something on that surface, not part of the object.
  const std::vector<std::vector<int>>& segments = work->segments;
  const float rest_m = static_cast<float>(config_.resting_distance_m);
  const float edge_m = static_cast<float>(config_.resting_edge_margin_m);
  for (int b = 0; b < work->num_segments; ++b) {
    Eigen::Vector3f n_b, p_b;
    if (!work->bounding[b] || !work->horizontal(b, config_.plane_max_thickness_m, &n_b, &p_b)) {
      continue;
    }
    // The surface's footprint, so that what hides part of it (papers on a table) stands inside.
    const std::vector<cv::Point2f> hull = work->footprintHull(b);
    if (hull.size() < 3) continue;
    for (int s = 0; s < work->num_segments; ++s) {
      if (s == b || work->bounding[s] || work->resting[s]) continue;
      // Its lowest point on the surface (heights along the surface's normal).
      float bottom = std::numeric_limits<float>::infinity();
      for (const int i : segments[s]) bottom = std::min(bottom, n_b.dot(work->points_W[i] - p_b));
      if (std::abs(bottom) > rest_m) continue;
      size_t over = 0;
      for (const int i : segments[s]) {
        const Eigen::Vector3f& p_W = work->points_W[i];
        const cv::Point2f q(work->x_h.dot(p_W), work->y_h.dot(p_W));
        over += edge_m > 0.f ? cv::pointPolygonTest(hull, q, true) >= edge_m
                             : cv::pointPolygonTest(hull, q, false) >= 0;
      }
      if (over >= config_.resting_min_share * segments[s].size()) {
        work->resting[s] = 1;
        ++result->resting_segments;
      }
    }
  }
}

bool SegmentSelector::chooseFlatSupport(Work* work) const {
  // A book on a table is part of the table's plane in depth, a wall monitor of the wall's: the
  // bounding segment with the most core points that is horizontal (lies_flat) or vertical (on_wall)
  // is what it lies or hangs on.
  int support = -1;
  for (int s = 0; s < work->num_segments; ++s) {
    Eigen::Vector3f n, p;
    if (!work->bounding[s] || work->core_count[s] == 0) continue;
    const bool lies_on =
        work->lies_flat && work->horizontal(s, config_.plane_max_thickness_m, &n, &p);
    const bool hangs_on = work->on_wall && work->vertical(s, config_.plane_max_thickness_m);
    if (!lies_on && !hangs_on) continue;
    if (support < 0 || work->core_count[s] > work->core_count[support]) support = s;
  }
  work->flat_support = support;
  return support >= 0;
}

bool SegmentSelector::findFlatTop(const Work& work, Eigen::Vector3f* top_normal_W,
                                  Eigen::Vector3f* top_point_W,
                                  std::vector<cv::Point2f>* top_hull) const {
  // flat_top classes: nothing above the main horizontal surface of the kept set (its largest
  // horizontal planar segment, if large enough; up to twice plane_max_thickness_m thick, as a top
  // with papers on it is) belongs to the object.
  const ClassPrior* prior = work.input.prior;
  if (prior == nullptr || !prior->flat_top || !(config_.top_clearance_m > 0.0)) return false;
  const std::vector<std::vector<int>>& segments = work.segments;
  int top = -1;
  for (int s = 0; s < work.num_segments; ++s) {
    Eigen::Vector3f n, p;
    if (!work.kept[s] || segments[s].size() < config_.top_min_share * work.kept_points) continue;
    if (!work.horizontal(s, 2.0 * config_.plane_max_thickness_m, &n, &p)) continue;
    if (top < 0 || segments[s].size() > segments[top].size()) {
      top = s;
      *top_normal_W = n;
      *top_point_W = p;
    }
  }
  if (top < 0) return false;
  *top_hull = work.footprintHull(top);
  return true;
}

bool SegmentSelector::belowFlatTop(const PointCloud& points_W, const Eigen::Vector3d& up_W,
                                   double clearance_m, double min_share, PointCloud* below_W) {
  if (points_W.empty() || !(clearance_m >= 0.0) || !(min_share > 0.0) || !up_W.allFinite() ||
      !(up_W.norm() > 0.0)) {
    return false;
  }
  const Eigen::Vector3f up = up_W.normalized().cast<float>();
  constexpr float kLayerM = 0.01f;
  std::vector<float> heights(points_W.size());
  float lowest = std::numeric_limits<float>::infinity();
  for (size_t i = 0; i < points_W.size(); ++i) {
    heights[i] = up.dot(points_W[i]);
    if (std::isfinite(heights[i])) lowest = std::min(lowest, heights[i]);
  }
  if (!std::isfinite(lowest)) return false;
  // Layers by their index above the lowest point.
  std::map<long, size_t> layers;
  for (const float h : heights) {
    if (std::isfinite(h)) ++layers[static_cast<long>(std::floor((h - lowest) / kLayerM))];
  }
  const double needed = min_share * static_cast<double>(points_W.size());
  long top = -1;
  for (const auto& layer : layers) {
    if (static_cast<double>(layer.second) >= needed) top = layer.first;
  }
  if (top < 0) return false;
  const float limit =
      lowest + static_cast<float>(top + 1) * kLayerM + static_cast<float>(clearance_m);
  below_W->clear();
  below_W->reserve(points_W.size());
  for (size_t i = 0; i < points_W.size(); ++i) {
    if (heights[i] <= limit) below_W->push_back(points_W[i]);
  }
  return !below_W->empty() && below_W->size() < points_W.size();
}

}  // namespace mvod
