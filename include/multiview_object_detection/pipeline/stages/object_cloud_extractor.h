// Eq. 1: instance masks + depth -> object point clouds.
#pragma once

#include <vector>

#include "multiview_object_detection/pipeline/types/detection.h"
#include "multiview_object_detection/pipeline/types/rgbd_frame.h"

namespace mvod {

class ObjectCloudExtractor {
 public:
  struct Config {
    // Depth values outside this range are invalid (besides 0, 65535 and NaN) (m).
    double min_valid_depth_m = 0.1;
    double max_valid_depth_m = 10.0;
    // Erode each mask by this many pixels first: mask borders bleed into the background.
    int mask_erosion_px = 0;
    // Use every n-th depth pixel in u and v (1 = all).
    int pixel_stride = 1;
    // Near surfaces on a coarser pixel grid: a pixel at depth z is used only where u and v are
    // multiples of floor(fx near_sampling_leaf_m / (2 z)), so a square of this side still gets 2 x
    // 2 pixels or more; the filter's voxel grid (of the same leaf) averages them anyway. A couch 1
    // m away then gives a quarter of the points at the same voxels. 0 = every pixel (the paper's
    // method). (m)
    double near_sampling_leaf_m = 0.01;
    // Outliers at depth edges, in the image (the default's replacement for the filter's k-NN
    // statistics): a pixel needs this many of its 4 neighbours (at pixel_stride) with a depth
    // within consistency_tolerance_m + 3 depth_step_per_m2 z^2 of its own. 0 = off (the paper's
    // method).
    int min_consistent_neighbours = 3;
    double consistency_tolerance_m = 0.01;
    double depth_step_per_m2 = 2.85e-3;  // Kinect v1 disparity steps: Δz = 2.85e-3 z^2
    // Mask borders at depth edges: a mask computed on a coarse grid (Detection2D::mask_cell_px)
    // runs up to a cell past its object's silhouette. A masked depth pixel within one cell of a
    // surface nearer than it by more than the same tolerance is the background the mask ran onto
    // (the table past a mug's rim, the wall beside a monitor) and is left out. The cell is used up
    // to this many pixels (YOLOv5-seg's cell: 4 px at its 640 input, 8 px at 320, on a 640 x 480
    // image); 0 = off (the paper's method). Masks of unknown or pixel resolution have no margin.
    int max_depth_edge_margin_px = 8;
    Status isValid() const;
    std::string print() const;
  };

  ObjectCloudExtractor() = default;
  explicit ObjectCloudExtractor(const Config& config) : config_(config) {}
  const Config& config() const { return config_; }

  // One cloud per detection, in the DEPTH camera frame (points_D); the caller transforms with
  // T_W_D. Each valid depth pixel is back-projected once; if the frame is not registered it is
  // projected into the colour image (T_C_D, K_color) to look up the masks. An empty cloud means the
  // mask held no valid depth.
  Status extract(const RgbdFrame& frame, const std::vector<Detection2D>& detections,
                 std::vector<PointCloud>* clouds_D) const;

  // Back-projects the whole depth image (every `stride`-th pixel), depth frame.
  static PointCloud backProjectDepth(const cv::Mat& depth, const CameraIntrinsics& K, int stride,
                                     double min_depth_m, double max_depth_m);
  // Depth in metres at (u, v), or NaN when invalid (0, 65535, NaN, out of range).
  static float depthAt(const cv::Mat& depth, int u, int v, double min_depth_m, double max_depth_m);
  // depthAt of `count` pixels of row v, from column u0 every `stride` columns, into out (all inside
  // the image): one pass per row instead of a look-up per pixel.
  static void depthRowAt(const cv::Mat& depth, int v, int u0, int stride, int count,
                         double min_depth_m, double max_depth_m, float* out);

 private:
  Config config_;
};

}  // namespace mvod
