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
// The class priors' shapes (ClassPrior): a class with large horizontal surfaces of its own (a
// table) keeps a horizontal plane that runs past its mask, as its top; a class that lies flat (a
// book on a table), whose core holds only its support's plane, is that plane inside its mask.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/class_priors.h"
#include "multiview_object_detection/pipeline/types/common.h"
#include "multiview_object_detection/pipeline/types/detection.h"
#include "multiview_object_detection/pipeline/types/oriented_box.h"
#include "multiview_object_detection/pipeline/types/rgbd_frame.h"

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
    // A vertical plane also needs min_ring_share of all the ring's points on it: a wall runs past
    // the detection along much of the ring, while a part of the object that an imprecise box
    // clips (a backrest's end) crosses it in a narrow band. So does a horizontal plane in the box
    // of an on_floor class (a clipped seat); for other classes a horizontal surface is their
    // support (a tv's stand, a cup's table) wherever it runs past. 0 = any count from
    // min_continuation_points.
    double min_ring_share = 0.1;
    // The kept segments stay within prior_size_slack x the class's prior size (+ 0.1 m).
    double prior_size_slack = 1.5;
    // Support surfaces (class priors on_floor / flat_top; 0 switches each off). A horizontal
    // segment is one whose plane normal lies within support_max_tilt_deg of up.
    // on_floor classes: a segment resting on a horizontal bounding surface (its lowest point within
    // resting_distance_m of the surface, and at least resting_min_share of its points over the
    // surface's footprint) is something on that surface, not part of the object: cups on the
    // table in a chair's box.
    double resting_distance_m = 0.04;
    double resting_min_share = 0.6;
    // ... over the surface's footprint shrunk by this margin: what rests on a table stands on its
    // top, while a backrest behind the table's edge rises beside it (and the top's segment may
    // hold a few of the backrest's lowest points, which widen the footprint up to it).
    double resting_edge_margin_m = 0.03;
    // When the core then holds only surfaces and what rests on them, the seed is the largest
    // other segment with at least this share of the cloud's points (the nearest would be the
    // legs of a chair pushed under a table, seen below its top, rather than its backrest).
    double fallback_min_share = 0.05;
    // flat_top classes: points more than top_clearance_m above the kept set's main horizontal
    // surface (the largest, holding at least top_min_share of the kept points) or more than
    // top_clearance_m outside its footprint are dropped, and so are whole segments with at least
    // top_crossing_share of their points above it: what stands on a table, and the backrests of
    // chairs pushed under it.
    double top_clearance_m = 0.03;
    double top_min_share = 0.15;
    double top_crossing_share = 0.1;
    double support_max_tilt_deg = 12.0;
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
    // The points of depth row v (v a multiple of stride) are [row_begin[v / stride],
    // row_begin[v / stride + 1]): a caller that needs some rows only skips the others.
    int stride = 1;
    std::vector<std::size_t> row_begin;
    // The points from depth rows [first_row, end_row) (clamped to the image), as an index range.
    std::pair<std::size_t, std::size_t> rows(int first_row, int end_row) const;
  };
  static FrameView makeFrameView(const RgbdFrame& frame, int stride, double min_depth_m,
                                 double max_depth_m);

  // The detection in colour pixels, on a crop around its box: its mask (a box-only detection
  // fills its box), its core and the ring just outside it. What select() needs of the image; it
  // does not depend on the cloud, so a caller with a spare thread computes it beside the filter
  // and LCCP (detectionMasks) and passes it in Input::masks.
  struct DetectionMasks {
    Status status;  // an error: the box lies outside the image, or covers (nearly) all of it
    cv::Rect crop;  // colour pixels
    cv::Mat mask;   // CV_8UC1 on the crop, 0 / non-zero
    cv::Mat core;   // the mask's core (the central share of a box-only detection's box)
    cv::Mat ring;   // the mask dilated by ring_px, less the mask
  };
  DetectionMasks detectionMasks(const Detection2D& detection, const cv::Size& image_size) const;

  // adjacent[a][b]: a point of segment a and one of segment b lie in the same or in neighbouring
  // cells of cell_m (voxelKeyOf's cells; a segment touches itself). On a dense grid of per-cell
  // segment bits for up to 64 segments over at most 2^24 cells, else by sorted packed cell keys.
  static std::vector<std::vector<char>> segmentAdjacency(
      const PointCloud& points, const std::vector<std::vector<int>>& segments, double cell_m);

  struct Input {
    const PointCloud* points_D = nullptr;  // the detection's cloud, depth-camera frame
    const std::vector<std::vector<int>>* segments = nullptr;  // indices into points_D
    const Detection2D* detection = nullptr;
    const RgbdFrame* frame = nullptr;   // K_color, T_C_D, T_W_D, image size
    const FrameView* view = nullptr;    // null: no bounding-surface test
    const ClassPrior* prior = nullptr;  // null or without size: no size limit
    GravityFrame gravity;
    // detectionMasks(*detection, the colour image's size), when computed already; null: select()
    // computes them.
    const DetectionMasks* masks = nullptr;
  };
  struct Result {
    std::vector<int> indices;  // into points_D, ascending
    int kept_segments = 0;
    int bounding_segments = 0;  // dropped as walls / surfaces running past the detection
    int resting_segments = 0;   // dropped as standing on another surface (on_floor classes)
    int above_top_points = 0;   // dropped above or beside a flat top (flat_top classes)
    int support_points = 0;     // dropped as the support around what stands on it
    // A class that lies flat (ClassPrior::liesFlat: a book) whose core held only the support's
    // plane: the object is that plane's points inside the mask, a thin box on the support.
    bool flat_on_support = false;
  };

  SegmentSelector() = default;
  explicit SegmentSelector(const Config& config) : config_(config) {}
  const Config& config() const { return config_; }

  // An error when nothing is left (every segment a bounding surface, or none in the core): the
  // caller skips the detection.
  Status select(const Input& input, Result* result) const;

  // The flat-top rule on a fused object (no segments): the top is the highest 1 cm layer (along
  // up_W) that holds min_share of the points; *below_W gets the points at most clearance_m above
  // that layer, in order. False (*below_W unspecified) when no layer holds min_share, nothing
  // lies above the limit, or nothing below it.
  static bool belowFlatTop(const PointCloud& points_W, const Eigen::Vector3d& up_W,
                           double clearance_m, double min_share, PointCloud* below_W);

 private:
  // One consistent selection's per-segment state (segment_selector.cpp).
  struct Work;
  // select()'s phases, in order.
  void countCorePoints(Work* work) const;
  // Planes of the segments of 20 points or more (thickness: RMS distance to the plane).
  void fitPlanes(Work* work) const;
  // Bounding surfaces: planar segments that continue in the ring outside the detection.
  void markBoundingSurfaces(const FrameView& view, Work* work, Result* result) const;
  // The points in the world frame and the segments' extents in the gravity frame.
  void computeExtents(Work* work) const;
  // on_floor classes: segments resting on a horizontal bounding surface.
  void markResting(Work* work, Result* result) const;
  // The segment with the most points in the core (or, when the core holds only excluded
  // segments, the largest other one of some size); an error where there is none.
  Status chooseSeed(Work* work, const Result& result) const;
  // Classes that lie flat: the horizontal bounding surface the core lies on; false if none.
  bool chooseFlatSupport(Work* work) const;
  // Touching segments join the seed while the union stays plausible in size.
  void growFromSeed(Work* work) const;
  // flat_top classes: the kept set's main horizontal surface, its plane and footprint.
  bool findFlatTop(const Work& work, Eigen::Vector3f* top_normal_W, Eigen::Vector3f* top_point_W,
                   std::vector<cv::Point2f>* top_hull) const;
  // Classes that stand on a support (not on_floor, on_wall or with large horizontal surfaces of
  // their own): the height of the horizontal surface around the detection that the kept set
  // (its heights along up from lowest_m to highest_m) reaches down to; false if none.
  bool findSupport(const Work& work, float lowest_m, float highest_m, float* support_m) const;
  // Per point: a kept point of the support around what stands on it (empty: none).
  std::vector<char> onSupport(const Work& work) const;
  // The kept segments' points (less the support's, and what rises above a flat top or lies
  // beside it), ascending.
  Status collectKept(const Work& work, Result* result) const;
  // Fewer points above the support: nothing stands on it, and its points stay.
  static constexpr std::size_t kMinStandingPoints = 10;

  Config config_;
};

}  // namespace mvod
