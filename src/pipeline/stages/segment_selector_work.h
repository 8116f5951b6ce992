// SegmentSelector's working state (one selection's input and what its phases find per segment),
// shared by segment_selector.cpp (the phases) and segment_selector_supports.cpp (what the object
// stands, lies or hangs on). Private to the pipeline library.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <cstddef>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "multiview_object_detection/pipeline/stages/segment_selector.h"
#include "segment_selector_geometry.h"

namespace mvod {

// One consistent selection's state: the input, and per segment what the phases of select() find.
struct SegmentSelector::Work {
  static constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

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
  std::vector<segment_selector_geometry::Plane>
      planes;                  // per segment; rms_m infinite: under 20 points, no plane
  std::vector<char> bounding;  // walls, surfaces running past the detection
  std::vector<char> resting;   // standing on a horizontal bounding surface (on_floor classes)
  PointCloud points_W;         // the points in the world frame
  std::vector<segment_selector_geometry::Extent> extents;  // per segment, in the gravity frame
  int seed = -1;
  // lies_flat: the support's segment the object lies on, when the core holds nothing else; the
  // object is then that segment's points inside the mask.
  int flat_support = -1;
  // stands_on_support: the heights along up of the view's points in the ring, ascending.
  std::vector<float> ring_heights_m;
  std::vector<char> kept;
  std::size_t kept_points = 0;
};

}  // namespace mvod
