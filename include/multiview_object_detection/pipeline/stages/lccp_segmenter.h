// Sec. 3.2 / Eq. 2: supervoxels + LCCP (locally convex connected patches); the largest segment is
// the object.
#pragma once

#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {

class LccpSegmenter {
 public:
  struct Config {
    bool enable = true;  // false = Table 3's "-LCCP" ablation (cloud passes through)
    // Who computes the supervoxels and LCCP's edge classification. "voxel_grid": this package, on a
    // hash voxel grid (adjacency by grid offsets, normals from neighbourhood moments), PCL's
    // algorithm without its octree. "pcl": pcl::SupervoxelClustering and pcl::LCCPSegmentation,
    // the paper's implementation. The grouping into segments is the same code for both.
    std::string implementation = "voxel_grid";
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
    // Threads for one cloud's voxel normals ("voxel_grid"; each voxel's is independent): the mapper
    // sets its pool's size here, so a large detection does not leave a core idle. The result does
    // not depend on it.
    int num_threads = 1;
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

  // Supervoxels and their adjacency with each edge classified (what LCCP's grouping needs).
  struct SupervoxelGraph {
    std::vector<int> point_supervoxel;       // per input point; -1: non-finite or in none
    std::vector<Eigen::Vector3f> centroids;  // per supervoxel: mean of its voxels' centroids
    std::vector<Eigen::Vector3f> normals;    // per supervoxel: unit (zero where undefined)
    std::vector<SupervoxelEdge> edges;       // a < b, ascending (a, b)
  };
  // The "voxel_grid" implementation: PCL's supervoxel clustering (voxels of voxel_resolution_m in
  // the log-depth space when log_transform, seeds on a seed_resolution_m grid, flow-constrained
  // expansion by spatial and normal distance) on a hash grid, then each adjacency classified by
  // convexConnection. Deterministic: voxels, seeds and supervoxels are in grid key order.
  Status gridSupervoxels(const PointCloud& points, bool log_transform,
                         SupervoxelGraph* graph) const;

  // LCCP's edge test (Stein et al. 2014) between patches s and t with centroids c and normals n
  // (normals point to the sensor): joined when the connection is convex, or concave with normals
  // within concavity_tolerance_deg; not where the sanity criterion (use_sanity_criterion) finds
  // convexity undefined, nor across a step (the smoothness criterion, smoothness_threshold).
  static bool convexConnection(const Eigen::Vector3f& c_s, const Eigen::Vector3f& n_s,
                               const Eigen::Vector3f& c_t, const Eigen::Vector3f& n_t,
                               const Config& config);

 private:
  Config config_;
};

}  // namespace mvod
