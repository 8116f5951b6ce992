// Which LCCP segments of one detection's cloud are the object.
//
// The paper (Eq. 2) keeps the largest segment. That fails on imperfect input: a mask that bleeds
// into the background, or a box-only detection (FastestDet, YOLO), brings floor, wall and
// neighbours into the cloud, and the largest segment is then often background; multi-part
// furniture (a chair's seat, back and legs) is cut at its concave joints and only one part kept.
//
// "consistent" keeps the segments that agree with the detection instead:
//   - bounding surfaces are dropped: a planar segment that continues, in the same plane, in a ring
//     of pixels just outside the detection (a wall behind the object, a table top under a cup);
//     the floor is cut before LCCP (FloorEstimator);
//   - the seed is the segment with the most points in the detection's core (the eroded mask, or
//     the central part of a box);
//   - segments that touch the kept ones in 3D join them while the union stays within the class's
//     prior size, so a chair's back and legs join its seat but the table beside it does not.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/class_priors.h"
#include "multiview_object_detection/pipeline/common.h"
#include "multiview_object_detection/pipeline/detection.h"
#include "multiview_object_detection/pipeline/oriented_box.h"
#include "multiview_object_detection/pipeline/rgbd_frame.h"

namespace mvod {

class SegmentSelector {
 public:
  struct Config {
    std::string selection = "consistent";  // largest (Eq. 2, the paper) | consistent
    // The detection's core: box-only detections keep this central share of the box's width and
    // height; masks are eroded by this share of their box's shorter side.
    double core_box_fraction = 0.5;
    double core_mask_erosion = 0.15;
    double adjacency_distance_m = 0.03;  // segments with points closer than this touch
    // Bounding surfaces: looked for in a ring this wide outside the detection. A segment is planar
    // when the RMS distance of its points to their plane is below plane_max_thickness_m; it
    // continues past the detection when at least min_continuation of the ring points near it (and
    // min_continuation_points) lie within plane_distance_m of its plane.
    int ring_px = 10;
    double plane_max_thickness_m = 0.012;
    double plane_distance_m = 0.02;
    double min_continuation = 0.4;
    int min_continuation_points = 10;
    // The kept segments stay within prior_size_slack x the class's prior size (+ 0.1 m).
    double prior_size_slack = 1.5;
    // A box covering more than this share of the image holds no object to cut from its
    // surroundings: the detection is skipped.
    double max_box_image_fraction = 0.9;
    Status isValid() const;
    std::string print() const;
    bool consistent() const { return selection == "consistent"; }
  };

  // One frame's depth points (every stride-th pixel) and their colour pixels, computed once per
  // keyframe for the bounding-surface test of every detection.
  struct FrameView {
    PointCloud points_D;
    PointCloud points_W;  // the same points in the world frame (T_W_D), computed once
    std::vector<cv::Point> pixels_color;  // (-1, -1): outside the colour image
  };
  static FrameView makeFrameView(const RgbdFrame& frame, int stride, double min_depth_m,
                                 double max_depth_m);

  struct Input {
    const PointCloud* points_D = nullptr;  // the detection's cloud, depth-camera frame
    const std::vector<std::vector<int>>* segments = nullptr;  // indices into points_D
    const Detection2D* detection = nullptr;
    const RgbdFrame* frame = nullptr;   // K_color, T_C_D, T_W_D, image size
    const FrameView* view = nullptr;    // null: no bounding-surface test
    const ClassPrior* prior = nullptr;  // null or without size: no size limit
    GravityFrame gravity;
  };
  struct Result {
    std::vector<int> indices;  // into points_D, ascending
    int kept_segments = 0;
    int bounding_segments = 0;  // dropped as walls / surfaces running past the detection
  };

  SegmentSelector() = default;
  explicit SegmentSelector(const Config& config) : config_(config) {}
  const Config& config() const { return config_; }

  // An error when nothing is left (every segment a bounding surface, or none in the core): the
  // caller skips the detection.
  Status select(const Input& input, Result* result) const;

 private:
  Config config_;
};

}  // namespace mvod
