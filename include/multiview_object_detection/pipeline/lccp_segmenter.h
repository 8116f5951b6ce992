// Sec. 3.2 / Eq. 2: supervoxels + LCCP (locally convex connected patches); the largest segment is
// the object.
#pragma once

#include "multiview_object_detection/pipeline/common.h"

namespace mvod {

class LccpSegmenter {
 public:
  struct Config {
    bool enable = true;  // false = Table 3's "-LCCP" ablation (cloud passes through)
    // Supervoxel octree leaf, coarser than the 0.01 m filter grid: Kinect rows on surfaces seen
    // at a grazing angle (box tops) lie ~2 cm apart at 2 m and must still be adjacent voxels.
    double voxel_resolution_m = 0.015;
    double seed_resolution_m = 0.05;  // supervoxel seed spacing
    double spatial_importance = 1.0;
    double normal_importance = 4.0;
    double color_importance = 0.0;  // clouds carry no colour
    // Log-transform depth before supervoxel clustering (PCL's single-camera transform) for
    // single-view clouds given in the camera frame: density falls with depth, the log keeps voxel
    // sizes fair.
    bool log_depth_transform = true;
    double concavity_tolerance_deg = 10.0;
    double smoothness_threshold = 0.1;
    // Segments of at most this many supervoxels are merged into a neighbour; small, so that a
    // cup's few supervoxels do not swallow bits of the table around it.
    int min_segment_size = 1;
    bool use_extended_convexity = false;
    bool use_sanity_criterion = true;
    int min_points = 30;  // fewer input points: no segmentation, cloud passes through
    Status isValid() const;
    std::string print() const;
  };

  struct Result {
    PointCloud largest_segment;  // Eq. 2
    // Every segment as indices into the input points, largest first (segments[0] is
    // largest_segment). Points in no supervoxel are in none. With LCCP disabled or a cloud too
    // small to split: one segment of all finite points.
    std::vector<std::vector<int>> segments;
    int num_supervoxels = 0;
    int num_segments = 0;
  };

  LccpSegmenter() = default;
  explicit LccpSegmenter(const Config& config) : config_(config) {}
  const Config& config() const { return config_; }

  // points_in_camera_frame: true when `points` are a single view in its optical frame (z = depth >
  // 0), which enables the log-depth transform; false for fused world-frame clouds (already
  // voxelised to uniform density). Supervoxel normals are flipped towards the origin of the points'
  // frame (PCL's convention) and convexity depends on that: give world-frame clouds relative to a
  // camera centre (points_W - t_W_C, add it back to the segment) when the world origin may lie
  // below or inside the object.
  Status segment(const PointCloud& points, bool points_in_camera_frame, Result* result) const;

  // An adjacency between supervoxels a and b (indices in ascending label order); convex = LCCP
  // joins them (convexity, sanity and smoothness criteria passed).
  struct SupervoxelEdge {
    int a = -1;
    int b = -1;
    bool convex = false;
  };
  // LCCP's grouping: the components of the convex edges, then segments of at most
  // min_segment_size supervoxels merged into their largest neighbour. Returns a segment id >= 1 per
  // supervoxel, numbered in the order of each segment's lowest supervoxel. Depends only on the
  // supervoxel order and the edges (not on the edges' order or on memory addresses).
  static std::vector<int> groupSupervoxels(int num_supervoxels,
                                           const std::vector<SupervoxelEdge>& edges,
                                           int min_segment_size);

 private:
  Config config_;
};

}  // namespace mvod
