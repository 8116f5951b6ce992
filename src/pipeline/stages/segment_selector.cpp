#include "multiview_object_detection/pipeline/stages/segment_selector.h"
// SegmentSelector: its Config and the phases of one selection (core, planes, bounding surfaces,
// seed, growth, the kept points). What the object stands, lies or hangs on:
// segment_selector_supports.cpp.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "multiview_object_detection/pipeline/stages/object_cloud_extractor.h"
#include "multiview_object_detection/pipeline/utils/voxel_key.h"
#include "segment_selector_geometry.h"
#include "segment_selector_work.h"

namespace mvod {
namespace {

constexpr double kPiOver18 = 3.14159265358979323846 / 18.0;

}  // namespace

using segment_selector_geometry::addToCell;
using segment_selector_geometry::CellSegments;
using segment_selector_geometry::countRingPoints;
using segment_selector_geometry::Extent;
using segment_selector_geometry::fitPlane;
using segment_selector_geometry::kDirections;
using segment_selector_geometry::NearSegments;
using segment_selector_geometry::Plane;
using segment_selector_geometry::ringHeights;
using segment_selector_geometry::segmentExtents;

Status SegmentSelector::Config::isValid() const {
  if (selection != "largest" && selection != "consistent") {
    return Status::Error("selection must be largest or consistent (got '" + selection + "')");
  }
  if (!(core_box_fraction > 0.0 && core_box_fraction <= 1.0)) {
    return Status::Error("core_box_fraction must be in (0, 1]");
  }
  if (!(core_mask_erosion >= 0.0 && core_mask_erosion < 0.5)) {
    return Status::Error("core_mask_erosion must be in [0, 0.5)");
  }
  if (!(std::isfinite(adjacency_distance_m) && adjacency_distance_m > 0.0)) {
    return Status::Error("adjacency_distance_m must be > 0");
  }
  if (ring_px < 1 || ring_px > 100) return Status::Error("ring_px must be in [1, 100]");
  if (!(plane_max_thickness_m >= 0.0 && plane_distance_m > 0.0 && min_continuation > 0.0 &&
        min_continuation <= 1.0 && min_continuation_points >= 1)) {
    return Status::Error(
        "plane_max_thickness_m >= 0, plane_distance_m > 0, min_continuation in (0, 1] and "
        "min_continuation_points >= 1 are required");
  }
  if (!(min_ring_share >= 0.0 && min_ring_share <= 1.0)) {
    return Status::Error("min_ring_share must be in [0, 1]");
  }
  if (!(std::isfinite(prior_size_slack) && prior_size_slack >= 1.0)) {
    return Status::Error("prior_size_slack must be >= 1");
  }
  if (!(max_box_image_fraction > 0.0 && max_box_image_fraction <= 1.0)) {
    return Status::Error("max_box_image_fraction must be in (0, 1]");
  }
  if (!(std::isfinite(resting_distance_m) && resting_distance_m >= 0.0 && resting_min_share > 0.0 &&
        resting_min_share <= 1.0)) {
    return Status::Error("resting_distance_m must be >= 0 and resting_min_share in (0, 1]");
  }
  if (!(std::isfinite(resting_edge_margin_m) && resting_edge_margin_m >= 0.0)) {
    return Status::Error("resting_edge_margin_m must be a finite value >= 0 (got " +
                         std::to_string(resting_edge_margin_m) + ")");
  }
  if (!(std::isfinite(top_clearance_m) && top_clearance_m >= 0.0 && top_min_share > 0.0 &&
        top_min_share <= 1.0 && top_crossing_share > 0.0 && top_crossing_share <= 1.0)) {
    return Status::Error(
        "top_clearance_m must be >= 0, top_min_share and top_crossing_share in (0, 1]");
  }
  if (!(fallback_min_share > 0.0 && fallback_min_share <= 1.0)) {
    return Status::Error("fallback_min_share must be in (0, 1]");
  }
  if (!(support_max_tilt_deg > 0.0 && support_max_tilt_deg < 90.0)) {
    return Status::Error("support_max_tilt_deg must be in (0, 90)");
  }
  return Status::Ok();
}

std::string SegmentSelector::Config::print() const {
  std::ostringstream out;
  out << "selection: " << selection << "\n"
      << "core_box_fraction: " << core_box_fraction << "\n"
      << "core_mask_erosion: " << core_mask_erosion << "\n"
      << "adjacency_distance_m: " << adjacency_distance_m << "\n"
      << "ring_px: " << ring_px << "\n"
      << "plane_max_thickness_m: " << plane_max_thickness_m << "\n"
      << "plane_distance_m: " << plane_distance_m << "\n"
      << "min_continuation: " << min_continuation << "\n"
      << "min_continuation_points: " << min_continuation_points << "\n"
      << "min_ring_share: " << min_ring_share << "\n"
      << "prior_size_slack: " << prior_size_slack << "\n"
      << "max_box_image_fraction: " << max_box_image_fraction << "\n"
      << "resting_distance_m: " << resting_distance_m << "\n"
      << "resting_min_share: " << resting_min_share << "\n"
      << "resting_edge_margin_m: " << resting_edge_margin_m << "\n"
      << "top_clearance_m: " << top_clearance_m << "\n"
      << "top_min_share: " << top_min_share << "\n"
      << "top_crossing_share: " << top_crossing_share << "\n"
      << "fallback_min_share: " << fallback_min_share << "\n"
      << "support_max_tilt_deg: " << support_max_tilt_deg << "\n";
  return out.str();
}

Status SegmentSelector::select(const Input& input, Result* result) const {
  if (result == nullptr || input.points_D == nullptr || input.segments == nullptr) {
    return Status::Error("SegmentSelector::select: missing input");
  }
  *result = Result();
  const std::vector<std::vector<int>>& segments = *input.segments;
  if (segments.empty() || segments[0].empty()) return Status::Error("no segment to select");
  if (!config_.consistent() || input.detection == nullptr || input.frame == nullptr) {
    // Eq. 2: the largest segment.
    result->indices = segments[0];
    std::sort(result->indices.begin(), result->indices.end());
    result->kept_segments = 1;
    return Status::Ok();
  }
  DetectionMasks computed;
  if (input.masks == nullptr) {
    computed = detectionMasks(*input.detection, input.frame->color_bgr.size());
  }
  const DetectionMasks& masks = input.masks != nullptr ? *input.masks : computed;
  if (!masks.status) return masks.status;

  Work work(input, masks, config_);
  countCorePoints(&work);
  fitPlanes(&work);
  if (input.view != nullptr) markBoundingSurfaces(*input.view, &work, result);
  if (input.view != nullptr && work.stands_on_support) {
    work.ring_heights_m = ringHeights(*input.view, work.masks, work.frame.registered, work.up);
  }
  computeExtents(&work);
  if (work.on_floor && config_.resting_distance_m > 0.0) markResting(&work, result);
  const Status seeded = chooseSeed(&work, *result);
  if (!seeded) return seeded;
  growFromSeed(&work);
  return collectKept(work, result);
}

void SegmentSelector::countCorePoints(Work* work) const {
  // Per point: in the core?
  const PointCloud& points = work->points;
  const cv::Rect& crop = work->masks.crop;
  const cv::Mat& core = work->masks.core;
  const cv::Mat& mask = work->masks.mask;
  std::vector<char> in_core(points.size(), 0);
  work->in_mask.assign(points.size(), 0);
  for (size_t i = 0; i < points.size(); ++i) {
    cv::Point pixel;
    if (colorPixelOf(work->frame, points[i].cast<double>(), &pixel) && crop.contains(pixel)) {
      in_core[i] = core.ptr<uint8_t>(pixel.y - crop.y)[pixel.x - crop.x] != 0;
      work->in_mask[i] = mask.ptr<uint8_t>(pixel.y - crop.y)[pixel.x - crop.x] != 0;
    }
  }
  work->core_count.assign(work->num_segments, 0);
  for (int s = 0; s < work->num_segments; ++s) {
    for (const int i : work->segments[s]) work->core_count[s] += in_core[i];
  }
}

void SegmentSelector::fitPlanes(Work* work) const {
  work->planes.resize(work->num_segments);
  for (int s = 0; s < work->num_segments; ++s) {
    work->planes[s].rms_m = std::numeric_limits<double>::infinity();
    if (work->segments[s].size() >= 20) work->planes[s] = fitPlane(work->points, work->segments[s]);
  }
}

void SegmentSelector::markBoundingSurfaces(const FrameView& view, Work* work,
                                           Result* result) const {
  // Bounding surfaces: planar segments that continue in the ring outside the detection.
  const int num_segments = work->num_segments;
  const std::vector<Plane>& planes = work->planes;
  const float near_cell_m = 0.05f;  // "near a segment": within one 5 cm cell of its points
  CellSegments near_cells;
  for (int s = 0; s < num_segments; ++s) {
    if (planes[s].rms_m > config_.plane_max_thickness_m) continue;
    for (const int i : work->segments[s]) {
      addToCell(&near_cells, voxelKeyOf(work->points[i], near_cell_m), s);
    }
  }
  if (near_cells.empty()) return;
  std::vector<int> near(num_segments, 0);
  std::vector<int> on_plane(num_segments, 0);
  const int ring_points = countRingPoints(view, work->masks, work->frame.registered, planes,
                                          NearSegments(near_cells, near_cell_m),
                                          config_.plane_distance_m, &near, &on_plane);
  const double ring_points_needed = config_.min_ring_share * ring_points;
  for (int s = 0; s < num_segments; ++s) {
    // What does not stand on the floor (a tv, a cup) stands on whatever horizontal surface
    // runs past its box; a floor-standing object's box holds no support of its own, so a
    // horizontal plane that crosses its ring narrowly is a part of it (a clipped seat).
    Eigen::Vector3f n, p;
    const bool horizontal = work->horizontal(s, config_.plane_max_thickness_m, &n, &p);
    // A class with large horizontal surfaces of its own: what runs past its mask is its top (a
    // table's, holed by what stands on it and clipped by the mask's edge), not a bounding surface.
    if (horizontal && work->own_horizontal) continue;
    const bool support = !work->on_floor && horizontal;
    work->bounding[s] = on_plane[s] >= config_.min_continuation_points &&
                        (support || on_plane[s] >= ring_points_needed) &&
                        on_plane[s] >= config_.min_continuation * near[s];
    result->bounding_segments += work->bounding[s];
  }
}

void SegmentSelector::computeExtents(Work* work) const {
  // Segments in the gravity frame: the points in the world frame, once; the extents along 18
  // horizontal directions and up.
  work->points_W.reserve(work->points.size());
  for (const Eigen::Vector3f& p : work->points) work->points_W.push_back(work->T_W_D * p);
  std::vector<Eigen::Vector3f> directions;
  for (int k = 0; k < kDirections; ++k) {
    const float a = static_cast<float>(k * kPiOver18);
    directions.push_back(std::cos(a) * work->x_h + std::sin(a) * work->y_h);
  }
  directions.push_back(work->up);
  work->extents = segmentExtents(work->points_W, work->segments, directions);
}

Status SegmentSelector::chooseSeed(Work* work, const Result& result) const {
  // The seed: the most points in the core.
  const std::vector<std::vector<int>>& segments = work->segments;
  const std::vector<int>& core_count = work->core_count;
  int seed = -1;
  for (int s = 0; s < work->num_segments; ++s) {
    if (work->excluded(s) || core_count[s] == 0) continue;
    if (seed < 0 || core_count[s] > core_count[seed]) seed = s;
  }
  if (seed < 0 && (work->lies_flat || work->on_wall) && chooseFlatSupport(work)) {
    return Status::Ok();
  }
  if (seed < 0 && (result.bounding_segments > 0 || result.resting_segments > 0)) {
    // The core holds only bounding surfaces and what rests on them (a chair pushed under a table
    // shows its backrest above the top, at the edge of its box): the largest other segment of
    // some size.
    const size_t min_points = static_cast<size_t>(config_.fallback_min_share * work->points.size());
    for (int s = 0; s < work->num_segments; ++s) {
      if (work->excluded(s) || segments[s].size() < std::max<size_t>(min_points, 1)) continue;
      if (seed < 0 || segments[s].size() > segments[seed].size()) seed = s;
    }
  }
  if (seed < 0) {
    return Status::Error(
        result.bounding_segments > 0
            ? "only surfaces running past the detection (wall, floor, table top) in its core"
            : "no segment in the detection's core");
  }
  work->seed = seed;
  return Status::Ok();
}

void SegmentSelector::growFromSeed(Work* work) const {
  if (work->seed < 0) return;  // lying flat on a support: nothing to grow
  // Adjacency between segments: points within adjacency_distance_m (neighbouring cells).
  const std::vector<std::vector<int>>& segments = work->segments;
  const std::vector<int>& core_count = work->core_count;
  const std::vector<std::vector<char>> adjacent =
      segmentAdjacency(work->points, segments, config_.adjacency_distance_m);
  // Touching segments join while the union stays plausible in size.
  double max_height_m = std::numeric_limits<double>::infinity();
  double max_short_m = std::numeric_limits<double>::infinity();
  double max_long_m = std::numeric_limits<double>::infinity();
  const ClassPrior* prior = work->input.prior;
  if (prior != nullptr && prior->has_size) {
    const Eigen::Vector3d& size = prior->size_m;
    max_height_m = config_.prior_size_slack * size.z() + 0.1;
    max_short_m = config_.prior_size_slack * std::min(size.x(), size.y()) + 0.1;
    max_long_m = config_.prior_size_slack * std::max(size.x(), size.y()) + 0.1;
  }
  auto plausible = [&](const Extent& e) {
    const Eigen::Array<float, kDirections + 1, 1> span = e.upper - e.lower;
    if (span[kDirections] > max_height_m) return false;
    int narrow = 0;
    for (int k = 1; k < kDirections; ++k) {
      if (span[k] < span[narrow]) narrow = k;
    }
    return span[narrow] <= max_short_m &&
           span[(narrow + kDirections / 2) % kDirections] <= max_long_m;
  };

  std::vector<char>& kept = work->kept;
  kept[work->seed] = 1;
  Extent kept_extent = work->extents[work->seed];
  work->kept_points = segments[work->seed].size();
  for (bool grew = true; grew;) {
    grew = false;
    // Best candidate first: the most core points, then the largest.
    int best = -1;
    for (int s = 0; s < work->num_segments; ++s) {
      if (kept[s] || work->excluded(s)) continue;
      bool touches = false;
      for (int t = 0; t < work->num_segments && !touches; ++t) touches = kept[t] && adjacent[s][t];
      if (!touches) continue;
      // A large segment with nothing in the core is background the detection only grazes.
      if (core_count[s] == 0 && segments[s].size() > work->kept_points) continue;
      Extent grown = kept_extent;
      grown.add(work->extents[s]);
      if (!plausible(grown)) continue;
      if (best < 0 || core_count[s] > core_count[best] ||
          (core_count[s] == core_count[best] && segments[s].size() > segments[best].size())) {
        best = s;
      }
    }
    if (best >= 0) {
      kept[best] = 1;
      kept_extent.add(work->extents[best]);
      work->kept_points += segments[best].size();
      grew = true;
    }
  }
}

Status SegmentSelector::collectKept(const Work& work, Result* result) const {
  const std::vector<std::vector<int>>& segments = work.segments;
  if (work.flat_support >= 0) {
    // The support's points inside the mask: a thin box on the support.
    for (const int i : segments[work.flat_support]) {
      if (work.in_mask[i]) result->indices.push_back(i);
    }
    std::sort(result->indices.begin(), result->indices.end());
    result->flat_on_support = true;
    result->kept_segments = 1;
    if (result->indices.empty()) return Status::Error("nothing of the support inside the mask");
    return Status::Ok();
  }
  Eigen::Vector3f top_normal_W, top_point_W;
  std::vector<cv::Point2f> top_hull;  // the top's footprint
  const bool has_top = findFlatTop(work, &top_normal_W, &top_point_W, &top_hull);
  // ... nor anything beyond the top's footprint (more than top_clearance_m outside its hull).
  const auto outside_top = [&](const Eigen::Vector3f& p_W) {
    return top_hull.size() >= 3 &&
           cv::pointPolygonTest(top_hull, cv::Point2f(work.x_h.dot(p_W), work.y_h.dot(p_W)), true) <
               -config_.top_clearance_m;
  };
  const float top_clearance_m = static_cast<float>(config_.top_clearance_m);
  const std::vector<char> on_support = onSupport(work);
  // The kept points marked, then collected in ascending order (segments do not share points).
  std::vector<char> take(work.points.size(), 0);
  std::size_t taken = 0;
  std::vector<char> dropped;  // above the top, or beside it
  for (int s = 0; s < work.num_segments; ++s) {
    if (!work.kept[s]) continue;
    dropped.assign(segments[s].size(), 0);
    if (!on_support.empty()) {
      for (size_t k = 0; k < segments[s].size(); ++k) {
        if (!on_support[segments[s][k]]) continue;
        ++result->support_points;
        dropped[k] = 2;  // the support's
      }
    }
    size_t num_above = 0;
    if (has_top) {
      for (size_t k = 0; k < segments[s].size(); ++k) {
        const Eigen::Vector3f& p_W = work.points_W[segments[s][k]];
        const bool above = top_normal_W.dot(p_W - top_point_W) > top_clearance_m;
        num_above += above;
        if (!dropped[k]) dropped[k] = above || outside_top(p_W);
      }
    }
    if (num_above > 0 && num_above >= config_.top_crossing_share * segments[s].size()) {
      result->above_top_points += static_cast<int>(segments[s].size());  // rises through the top
      continue;
    }
    ++result->kept_segments;
    for (size_t k = 0; k < segments[s].size(); ++k) {
      if (dropped[k]) {
        result->above_top_points += dropped[k] == 1;
        continue;
      }
      taken += take[segments[s][k]] == 0;
      take[segments[s][k]] = 1;
    }
  }
  if (taken == 0) return Status::Error("nothing left below the object's top surface");
  result->indices.reserve(taken);
  for (std::size_t i = 0; i < take.size(); ++i) {
    if (take[i]) result->indices.push_back(static_cast<int>(i));
  }
  return Status::Ok();
}

}  // namespace mvod
