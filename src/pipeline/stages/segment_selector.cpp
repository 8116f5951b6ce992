#include "multiview_object_detection/pipeline/stages/segment_selector.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <map>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "multiview_object_detection/pipeline/stages/object_cloud_extractor.h"
#include "multiview_object_detection/pipeline/utils/voxel_key.h"
#include "segment_selector_geometry.h"

namespace mvod {
namespace {

constexpr double kPiOver18 = 3.14159265358979323846 / 18.0;
constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
// The share of a detection's ring that the support around it holds: the ring of a cup on a table
// is mostly table top, while a wall, a shelf of books or a cluttered background spreads over many
// heights. From 0.2 to 0.4 the AP and per-object IoUs of the redkitchen with YOLOv5n-seg, of make
// demo's room and of the synthetic rooms were the same; at 0.1 the synthetic rooms' books lost
// (segmentation AP 3.3 -> 3.1), at 0.5 make demo's book (IoU 0.67 -> 0.24).
constexpr double kSupportMinRingShare = 0.3;

}  // namespace

using segment_selector_geometry::addToCell;
using segment_selector_geometry::CellSegments;
using segment_selector_geometry::countRingPoints;
using segment_selector_geometry::densestBand;
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

// One consistent selection's state: the input, and per segment what the phases of select() find.
struct SegmentSelector::Work {
  Work(const Input& in, const DetectionMasks& detection_masks, const Config& config)
      : input(in),
        points(*in.points_D),
        segments(*in.segments),
        frame(*in.frame),
        masks(detection_masks),
        num_segments(static_cast<int>(segments.size())),
        T_W_D(frame.T_W_D.cast<float>()),
        R_W_D(T_W_D.linear()),
        up(in.gravity.up.cast<float>()),
        x_h(in.gravity.x_h.cast<float>()),
        y_h(in.gravity.y_h.cast<float>()),
        cos_tilt(std::cos(config.support_max_tilt_deg * kDegToRad)),
        sin_tilt(std::sin(config.support_max_tilt_deg * kDegToRad)),
        on_floor(in.prior != nullptr && in.prior->on_floor),
        own_horizontal(in.prior != nullptr && in.prior->hasLargeHorizontalSurface()),
        lies_flat(in.prior != nullptr && in.prior->liesFlat()),
        on_wall(in.prior != nullptr && in.prior->on_wall),
        stands_on_support(!on_floor && !own_horizontal && !on_wall),
        bounding(num_segments, 0),
        resting(num_segments, 0),
        kept(num_segments, 0) {}

  // A horizontal planar segment (RMS thickness at most max_rms_m): its plane in the world frame,
  // normal up.
  bool horizontal(int s, double max_rms_m, Eigen::Vector3f* normal_W,
                  Eigen::Vector3f* point_W) const {
    if (!(planes[s].rms_m <= max_rms_m)) return false;
    Eigen::Vector3f n = R_W_D * planes[s].normal.cast<float>();
    if (n.dot(up) < 0.f) n = -n;
    if (n.dot(up) < cos_tilt) return false;
    *normal_W = n;
    *point_W = T_W_D * planes[s].point.cast<float>();
    return true;
  }
  // A vertical planar segment (a wall): its normal within the support tilt of horizontal.
  bool vertical(int s, double max_rms_m) const {
    if (!(planes[s].rms_m <= max_rms_m)) return false;
    const Eigen::Vector3f n = R_W_D * planes[s].normal.cast<float>();
    return std::abs(n.dot(up)) <= sin_tilt;
  }
  // A segment's footprint: the convex hull of its points on the horizontal plane.
  std::vector<cv::Point2f> footprintHull(int s) const {
    std::vector<cv::Point2f> footprint;
    footprint.reserve(segments[s].size());
    for (const int i : segments[s]) {
      const Eigen::Vector3f& p_W = points_W[i];
      footprint.emplace_back(x_h.dot(p_W), y_h.dot(p_W));
    }
    std::vector<cv::Point2f> hull;
    if (!footprint.empty()) cv::convexHull(footprint, hull);
    return hull;
  }
  bool excluded(int s) const { return bounding[s] || resting[s]; }

  const Input& input;
  const PointCloud& points;
  const std::vector<std::vector<int>>& segments;
  const RgbdFrame& frame;
  const DetectionMasks& masks;
  const int num_segments;
  // The gravity frame; horizontal planes in the world frame.
  const Eigen::Isometry3f T_W_D;
  const Eigen::Matrix3f R_W_D;
  const Eigen::Vector3f up;
  const Eigen::Vector3f x_h;
  const Eigen::Vector3f y_h;
  const double cos_tilt;
  const double sin_tilt;
  const bool on_floor;
  const bool own_horizontal;     // a horizontal plane running past is the object's (a table top)
  const bool lies_flat;          // the object lies flat on a support (a book on a table)
  const bool on_wall;            // the object hangs flat on a wall (a wall monitor)
  const bool stands_on_support;  // the object stands on a support's surface (a cup on a table)
  std::vector<char> in_mask;     // per point: its colour pixel in the detection's mask
  std::vector<int> core_count;   // per segment: its points in the detection's core
  std::vector<Plane> planes;     // per segment; rms_m infinite: under 20 points, no plane
  std::vector<char> bounding;    // walls, surfaces running past the detection
  std::vector<char> resting;     // standing on a horizontal bounding surface (on_floor classes)
  PointCloud points_W;           // the points in the world frame
  std::vector<Extent> extents;   // per segment, in the gravity frame
  int seed = -1;
  // lies_flat: the support's segment the object lies on, when the core holds nothing else; the
  // object is then that segment's points inside the mask.
  int flat_support = -1;
  // stands_on_support: the heights along up of the view's points in the ring, ascending.
  std::vector<float> ring_heights_m;
  std::vector<char> kept;
  std::size_t kept_points = 0;
};

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
