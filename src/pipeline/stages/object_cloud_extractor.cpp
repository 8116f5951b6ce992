#include "multiview_object_detection/pipeline/stages/object_cloud_extractor.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "multiview_object_detection/pipeline/types/map_limits.h"

namespace mvod {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// Depth in metres at one pixel of a CV_16UC1 (mm) or CV_32FC1 (m) image, NaN when invalid. The
// caller checks type and bounds.
inline double depthMetres(const cv::Mat& depth, int u, int v, double min_depth_m,
                          double max_depth_m) {
  double z;
  if (depth.type() == CV_16UC1) {
    const uint16_t mm = depth.ptr<uint16_t>(v)[u];
    // 0 = no return; 65535 = saturated / invalid on Kinect-style sensors (7-Scenes).
    if (mm == 0 || mm == 65535) return std::nan("");
    z = 0.001 * mm;
  } else {
    z = depth.ptr<float>(v)[u];
    if (!std::isfinite(z) || z <= 0.0) return std::nan("");
  }
  if (z < min_depth_m || z > max_depth_m) return std::nan("");
  return z;
}

bool supportedDepth(const cv::Mat& depth) {
  return !depth.empty() && (depth.type() == CV_16UC1 || depth.type() == CV_32FC1);
}

// One detection's mask, prepared for per-pixel lookups: its bounding box of non-zero pixels lets
// most pixels skip the mask read.
struct MaskLookup {
  cv::Mat mask;      // CV_8UC1
  cv::Point origin;  // colour pixel of mask pixel (0, 0)
  cv::Rect box;      // non-zero pixels, colour pixels; empty = nothing to select
  int depth_edge_margin_px = 0;
  // Per depth pixel of near_edge_region, the depth of the nearest near-side edge within the margin
  // (+inf where there is none); null when the margin is 0. Shared by the masks of one margin.
  const cv::Mat* near_edge_m = nullptr;
  cv::Point near_edge_origin;  // depth pixel of near_edge_m's (0, 0)
};

}  // namespace

Status ObjectCloudExtractor::Config::isValid() const {
  if (!(std::isfinite(min_valid_depth_m) && min_valid_depth_m >= 0.0)) {
    return Status::Error("min_valid_depth_m must be a finite value >= 0 (got " +
                         std::to_string(min_valid_depth_m) + ")");
  }
  if (!(std::isfinite(max_valid_depth_m) && max_valid_depth_m > min_valid_depth_m &&
        max_valid_depth_m <= kMaxSensorRangeM)) {
    return Status::Error("max_valid_depth_m must be > min_valid_depth_m and at most " +
                         std::to_string(static_cast<int>(kMaxSensorRangeM)) + " m (got " +
                         std::to_string(max_valid_depth_m) + ")");
  }
  if (mask_erosion_px < 0 || mask_erosion_px > 100) {
    return Status::Error("mask_erosion_px must be in [0, 100] (got " +
                         std::to_string(mask_erosion_px) + ")");
  }
  if (max_depth_edge_margin_px < 0 || max_depth_edge_margin_px > 50) {
    return Status::Error("max_depth_edge_margin_px must be in [0, 50] (got " +
                         std::to_string(max_depth_edge_margin_px) + ")");
  }
  if (min_consistent_neighbours < 0 || min_consistent_neighbours > 4) {
    return Status::Error("min_consistent_neighbours must be in [0, 4] (got " +
                         std::to_string(min_consistent_neighbours) + ")");
  }
  if (!(std::isfinite(consistency_tolerance_m) && consistency_tolerance_m >= 0.0) ||
      !(std::isfinite(depth_step_per_m2) && depth_step_per_m2 >= 0.0 && depth_step_per_m2 < 0.1)) {
    return Status::Error("consistency_tolerance_m must be >= 0 and depth_step_per_m2 in [0, 0.1)");
  }
  if (!(std::isfinite(near_sampling_leaf_m) && near_sampling_leaf_m >= 0.0 &&
        near_sampling_leaf_m <= 0.1)) {
    return Status::Error("near_sampling_leaf_m must be in [0, 0.1] m (got " +
                         std::to_string(near_sampling_leaf_m) + ")");
  }
  if (pixel_stride < 1 || pixel_stride > 64) {
    return Status::Error("pixel_stride must be in [1, 64] (got " + std::to_string(pixel_stride) +
                         ")");
  }
  return Status::Ok();
}

std::string ObjectCloudExtractor::Config::print() const {
  std::ostringstream out;
  out << "min_valid_depth_m: " << min_valid_depth_m << "\n"
      << "max_valid_depth_m: " << max_valid_depth_m << "\n"
      << "mask_erosion_px: " << mask_erosion_px << "\n"
      << "pixel_stride: " << pixel_stride << "\n"
      << "near_sampling_leaf_m: " << near_sampling_leaf_m << "\n"
      << "min_consistent_neighbours: " << min_consistent_neighbours << "\n"
      << "max_depth_edge_margin_px: " << max_depth_edge_margin_px << "\n"
      << "consistency_tolerance_m: " << consistency_tolerance_m << "\n"
      << "depth_step_per_m2: " << depth_step_per_m2 << "\n";
  return out.str();
}

float ObjectCloudExtractor::depthAt(const cv::Mat& depth, int u, int v, double min_depth_m,
                                    double max_depth_m) {
  if (!supportedDepth(depth) || u < 0 || v < 0 || u >= depth.cols || v >= depth.rows) return kNaN;
  const double z = depthMetres(depth, u, v, min_depth_m, max_depth_m);
  return std::isfinite(z) ? static_cast<float>(z) : kNaN;
}

void ObjectCloudExtractor::depthRowAt(const cv::Mat& depth, int v, int u0, int stride, int count,
                                      double min_depth_m, double max_depth_m, float* out) {
  if (!supportedDepth(depth) || v < 0 || v >= depth.rows || u0 < 0 || stride < 1 ||
      (count > 0 && u0 + static_cast<std::int64_t>(count - 1) * stride >= depth.cols)) {
    std::fill(out, out + std::max(0, count), kNaN);
    return;
  }
  // depthMetres with the type's branch out of the loop.
  const auto ranged = [min_depth_m, max_depth_m](double z) {
    return z < min_depth_m || z > max_depth_m ? kNaN : static_cast<float>(z);
  };
  if (depth.type() == CV_16UC1) {
    const uint16_t* row = depth.ptr<uint16_t>(v) + u0;
    for (int k = 0; k < count; ++k, row += stride) {
      out[k] = *row == 0 || *row == 65535 ? kNaN : ranged(0.001 * *row);
    }
  } else {
    const float* row = depth.ptr<float>(v) + u0;
    for (int k = 0; k < count; ++k, row += stride) {
      const double z = *row;
      out[k] = !std::isfinite(z) || z <= 0.0 ? kNaN : ranged(z);
    }
  }
}

PointCloud ObjectCloudExtractor::backProjectDepth(const cv::Mat& depth, const CameraIntrinsics& K,
                                                  int stride, double min_depth_m,
                                                  double max_depth_m) {
  PointCloud points_D;
  if (!supportedDepth(depth) || !K.isValid()) return points_D;
  if (stride < 1) stride = 1;
  points_D.reserve(static_cast<size_t>((depth.rows + stride - 1) / stride) *
                   ((depth.cols + stride - 1) / stride));
  for (int v = 0; v < depth.rows; v += stride) {
    for (int u = 0; u < depth.cols; u += stride) {
      const double z = depthMetres(depth, u, v, min_depth_m, max_depth_m);
      if (!std::isfinite(z)) continue;
      // Pinhole back-projection in the depth camera frame.
      points_D.emplace_back(static_cast<float>((u - K.cx) * z / K.fx),
                            static_cast<float>((v - K.cy) * z / K.fy), static_cast<float>(z));
    }
  }
  return points_D;
}

namespace {

// A detection's margin (Config::max_depth_edge_margin_px): its mask's cell, rounded, at most the
// maximum; 0 without a known cell.
int depthEdgeMarginPx(const Detection2D& detection, const ObjectCloudExtractor::Config& config) {
  const float cell_px = detection.mask_cell_px;
  if (!(cell_px > 1.f) || !std::isfinite(cell_px)) return 0;
  return static_cast<int>(std::min<long>(std::lround(cell_px), config.max_depth_edge_margin_px));
}

// The detections' masks prepared for look-ups (eroded by mask_erosion_px first), all checked
// before any work, so a bad one leaves no partial output. An empty mask gives no pixels.
Status prepareMasks(const RgbdFrame& frame, const std::vector<Detection2D>& detections,
                    const ObjectCloudExtractor::Config& config, const std::string& label,
                    std::vector<MaskLookup>* masks) {
  // Masks are in colour pixels.
  const cv::Size color_size = frame.color_bgr.size();
  masks->assign(detections.size(), MaskLookup());
  cv::Mat kernel;
  if (config.mask_erosion_px > 0) {
    const int k = 2 * config.mask_erosion_px + 1;
    kernel = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(k, k));
  }
  const cv::Rect image_rect(cv::Point(0, 0), color_size);
  for (size_t i = 0; i < detections.size(); ++i) {
    const cv::Mat& mask = detections[i].mask;
    if (mask.empty()) continue;  // no pixels: an empty cloud
    cv::Point origin;
    if (!maskOrigin(detections[i], color_size, &origin)) {
      const cv::Rect& box = detections[i].box_px;
      return Status::Error(
          label + ": detection " + std::to_string(i) + " (" + detections[i].class_name +
          "): mask is " + std::to_string(mask.cols) + "x" + std::to_string(mask.rows) + " " +
          matTypeName(mask) + ", expected 8UC1 of its box's size " + std::to_string(box.width) +
          "x" + std::to_string(box.height) + " or of the colour image's " +
          std::to_string(color_size.width) + "x" + std::to_string(color_size.height));
    }
    MaskLookup& lookup = (*masks)[i];
    if (config.mask_erosion_px > 0) {
      // Mask borders bleed into the background; the image border does not erode (OpenCV
      // default). The mask is eroded on its rectangle grown by the radius, so the pixels just
      // outside it count as background, as they would on the whole image.
      const int r = config.mask_erosion_px;
      const cv::Rect region =
          cv::Rect(origin.x - r, origin.y - r, mask.cols + 2 * r, mask.rows + 2 * r) & image_rect;
      cv::erode(maskInRegion(detections[i], color_size, region), lookup.mask, kernel);
      lookup.origin = region.tl();
    } else {
      lookup.mask = mask;
      lookup.origin = origin;
    }
    lookup.box = nonZeroBounds(lookup.mask) + lookup.origin;
    lookup.depth_edge_margin_px = depthEdgeMarginPx(detections[i], config);
  }
  return Status::Ok();
}

// The union of the masks over the boxes' union (any_box), once: the consistency test (four more
// depth reads) and the per-detection look-ups then run only on pixels some mask covers.
cv::Mat coveredByMasks(const std::vector<MaskLookup>& masks, const cv::Rect& any_box) {
  cv::Mat covered(any_box.size(), CV_8UC1, cv::Scalar(0));
  for (const MaskLookup& m : masks) {
    if (m.box.empty()) continue;
    const cv::Mat source = m.mask(m.box - m.origin);
    cv::Mat target = covered(m.box - any_box.tl());
    cv::bitwise_or(target, source, target);
  }
  return covered;
}

// The near-sampling grid (Config::near_sampling_leaf_m): whether pixel (u, v) at depth z is on
// the grid of its depth's stride, floor(px_per_m / z) with px_per_m = fx leaf / 2. Always true
// when px_per_m is 0 (off) or the stride is 1 (beyond fx leaf / 2 metres).
inline bool onNearSamplingGrid(int u, int v, double z, double px_per_m) {
  if (!(px_per_m > 0.0)) return true;
  const int stride = static_cast<int>(std::min(64.0, px_per_m / z));
  return stride <= 1 || (u % stride == 0 && v % stride == 0);
}

// The depth tolerance at z: the consistency tolerance plus three of the sensor's depth steps.
inline double depthToleranceM(double z, const ObjectCloudExtractor::Config& config) {
  return config.consistency_tolerance_m + 3.0 * config.depth_step_per_m2 * z * z;
}

// Depth-edge outliers: a pixel is kept when enough of its four neighbours (at the stride) have a
// depth within a few of the sensor's depth steps of its own. A line of flying pixels between an
// object and the background, or an isolated speckle, has at most two such neighbours; a
// surface's pixels have four, or three on a straight silhouette edge. Corners and diagonal edges
// of a silhouette (and the image's corners) have two: there it acts as a one-pixel erosion at
// depth edges, which also trims a mask's bleed there. (Measured on the benchmark rooms: with the
// eight neighbours and three of them, box mAP@0.5 was 7 points lower.)
bool consistentDepth(const cv::Mat& depth, int u, int v, double z,
                     const ObjectCloudExtractor::Config& config) {
  const int min_neighbours = config.min_consistent_neighbours;
  if (min_neighbours <= 0) return true;
  const int stride = config.pixel_stride;
  const double tolerance_m = depthToleranceM(z, config);
  static constexpr int kDu[4] = {1, -1, 0, 0};
  static constexpr int kDv[4] = {0, 0, 1, -1};
  int agreeing = 0;
  for (int n = 0; n < 4; ++n) {
    const int un = u + kDu[n] * stride;
    const int vn = v + kDv[n] * stride;
    if (un < 0 || vn < 0 || un >= depth.cols || vn >= depth.rows) continue;
    const double zn =
        depthMetres(depth, un, vn, config.min_valid_depth_m, config.max_valid_depth_m);
    if (std::abs(zn - z) <= tolerance_m) ++agreeing;  // false for NaN
  }
  return agreeing >= min_neighbours;
}

// The depths in metres of depth row v over `width` columns from first_column, NaN where invalid
// or outside the image.
void fillDepthRow(const cv::Mat& depth, int v, int first_column, int width, double min_m,
                  double max_m, double* row) {
  for (int k = 0; k < width; ++k) {
    const int u = first_column + k;
    row[k] = (v < 0 || v >= depth.rows || u < 0 || u >= depth.cols)
                 ? std::nan("")
                 : depthMetres(depth, u, v, min_m, max_m);
  }
}

// The depth of every near-side edge pixel (+inf elsewhere). A near-side edge pixel has a
// 4-neighbour farther than it by more than the depth tolerance: the silhouette of a mug against
// the table behind it. A surface seen at a grazing angle, however steep, has none (its
// neighbouring pixels step by less than the tolerance).
// Over `region` of the depth image (the result's pixel (0, 0) is region.tl()).
cv::Mat nearEdgeDepths(const cv::Mat& depth, const cv::Rect& region,
                       const ObjectCloudExtractor::Config& config) {
  const float inf = std::numeric_limits<float>::infinity();
  // The region's depths with a one-pixel border (NaN outside the image).
  const cv::Rect grown(region.x - 1, region.y - 1, region.width + 2, region.height + 2);
  cv::Mat depth_m(grown.size(), CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  const cv::Rect inside = grown & cv::Rect(0, 0, depth.cols, depth.rows);
  for (int v = inside.y; v < inside.br().y; ++v) {
    ObjectCloudExtractor::depthRowAt(depth, v, inside.x, 1, inside.width, config.min_valid_depth_m,
                                     config.max_valid_depth_m,
                                     depth_m.ptr<float>(v - grown.y) + (inside.x - grown.x));
  }
  cv::Mat edge_m(region.size(), CV_32FC1, cv::Scalar(inf));
  const auto farther = [&](float z, int u, int v) {  // grown's pixel; false for NaN
    const float zn = depth_m.ptr<float>(v)[u];
    return zn - z > depthToleranceM(zn, config);
  };
  for (int v = 1; v <= region.height; ++v) {
    const float* row = depth_m.ptr<float>(v);
    float* edge_row = edge_m.ptr<float>(v - 1);
    for (int u = 1; u <= region.width; ++u) {
      const float z = row[u];
      if (!std::isfinite(z)) continue;
      if (farther(z, u + 1, v) || farther(z, u - 1, v) || farther(z, u, v + 1) ||
          farther(z, u, v - 1)) {
        edge_row[u - 1] = z;
      }
    }
  }
  return edge_m;
}

// Each mask's near-edge look-up (MaskLookup::near_edge_m): the nearest near-side edge depth within
// its margin (a square window, the minimum of nearEdgeDepths over it), one map per margin in use.
// `region`: the depth pixels that may be looked up (a registered frame: the masks' boxes).
void attachNearEdges(const cv::Mat& depth, const cv::Rect& region,
                     const ObjectCloudExtractor::Config& config, std::vector<MaskLookup>* masks,
                     std::map<int, cv::Mat>* near_edge_by_margin) {
  cv::Mat edge_m;
  for (MaskLookup& m : *masks) {
    const int margin_px = m.depth_edge_margin_px;
    if (margin_px <= 0 || m.box.empty()) continue;
    cv::Mat& near_edge_m = (*near_edge_by_margin)[margin_px];
    if (near_edge_m.empty()) {
      if (edge_m.empty()) edge_m = nearEdgeDepths(depth, region, config);
      const cv::Mat window =
          cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * margin_px + 1, 2 * margin_px + 1));
      cv::erode(edge_m, near_edge_m, window, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT,
                cv::Scalar(std::numeric_limits<float>::infinity()));
    }
    m.near_edge_m = &near_edge_m;
    m.near_edge_origin = region.tl();
  }
}

// Whether mask m takes the depth pixel (u, v) at z: not on the far side of a depth edge within
// its margin.
inline bool clearOfDepthEdge(const MaskLookup& m, int u, int v, double z, double tolerance_m) {
  return m.near_edge_m == nullptr ||
         !(z - m.near_edge_m->ptr<float>(v - m.near_edge_origin.y)[u - m.near_edge_origin.x] >
           tolerance_m);
}

// Same pixel grid (a registered frame): only depth pixels inside some mask matter. The stride grid
// stays anchored at (0, 0), as in backProjectDepth. The depths in metres of the rows at v - stride,
// v and v + stride over the masks' columns (and one stride either side) are read once per row into
// buffers, NaN where invalid or outside the image, so the test of the four neighbours reads them
// without bounds checks: the same values and tests as consistentDepth's per pixel.
void extractRegistered(const RgbdFrame& frame, const std::vector<MaskLookup>& masks,
                       const cv::Rect& any_box, const cv::Mat& covered,
                       const ObjectCloudExtractor::Config& config,
                       std::vector<PointCloud>* clouds_D) {
  const cv::Mat& depth = frame.depth;
  const CameraIntrinsics& K_d = frame.K_depth;
  const int stride = config.pixel_stride;
  const double min_m = config.min_valid_depth_m;
  const double max_m = config.max_valid_depth_m;
  const int min_neighbours = config.min_consistent_neighbours;
  const int u0 = (any_box.x + stride - 1) / stride * stride;
  const int v0 = (any_box.y + stride - 1) / stride * stride;
  const int u_end = any_box.br().x;
  const int first_column = u0 - stride;  // buffer index 0
  const int width = u_end + stride - first_column + 1;
  std::vector<double> rows(3 * static_cast<size_t>(width));
  double* above = rows.data();
  double* here = above + width;
  double* below = here + width;
  fillDepthRow(depth, v0 - stride, first_column, width, min_m, max_m, above);
  fillDepthRow(depth, v0, first_column, width, min_m, max_m, here);
  const double tolerance_base_m = config.consistency_tolerance_m;
  const double tolerance_per_m2 = 3.0 * config.depth_step_per_m2;
  const double near_px_per_m = 0.5 * K_d.fx * config.near_sampling_leaf_m;
  std::vector<size_t> row_masks;  // the masks whose boxes hold row v
  for (int v = v0; v < any_box.br().y; v += stride) {
    fillDepthRow(depth, v + stride, first_column, width, min_m, max_m, below);
    row_masks.clear();
    for (size_t i = 0; i < masks.size(); ++i) {
      if (v >= masks[i].box.y && v < masks[i].box.br().y) row_masks.push_back(i);
    }
    const uint8_t* covered_row = covered.ptr<uint8_t>(v - any_box.y);
    for (int u = u0; u < u_end; u += stride) {
      if (covered_row[u - any_box.x] == 0) continue;
      const int k = u - first_column;
      const double z = here[k];
      if (!std::isfinite(z)) continue;
      if (!onNearSamplingGrid(u, v, z, near_px_per_m)) continue;
      const double tolerance_m = tolerance_base_m + tolerance_per_m2 * z * z;
      if (min_neighbours > 0) {
        // false for NaN
        const int agreeing = (std::abs(here[k + stride] - z) <= tolerance_m) +
                             (std::abs(here[k - stride] - z) <= tolerance_m) +
                             (std::abs(below[k] - z) <= tolerance_m) +
                             (std::abs(above[k] - z) <= tolerance_m);
        if (agreeing < min_neighbours) continue;
      }
      const Eigen::Vector3f p_D(static_cast<float>((u - K_d.cx) * z / K_d.fx),
                                static_cast<float>((v - K_d.cy) * z / K_d.fy),
                                static_cast<float>(z));
      // To every mask of this row that covers (u, v).
      for (const size_t i : row_masks) {
        const MaskLookup& m = masks[i];
        if (u < m.box.x || u >= m.box.br().x) continue;
        if (m.mask.ptr<uint8_t>(v - m.origin.y)[u - m.origin.x] != 0 &&
            clearOfDepthEdge(m, u, v, z, tolerance_m)) {
          (*clouds_D)[i].push_back(p_D);
        }
      }
    }
    std::swap(above, here);
    std::swap(here, below);
  }
}

// Not registered (two cameras): each depth point is moved into the colour camera (T_C_D) and
// projected with K_color; the mask is read at the nearest colour pixel. Every depth pixel may
// land in a mask.
void extractUnregistered(const RgbdFrame& frame, const std::vector<MaskLookup>& masks,
                         const cv::Rect& any_box, const cv::Mat& covered,
                         const ObjectCloudExtractor::Config& config,
                         std::vector<PointCloud>* clouds_D) {
  const cv::Mat& depth = frame.depth;
  const CameraIntrinsics& K_d = frame.K_depth;
  const int stride = config.pixel_stride;
  auto inSomeMask = [&](int uc, int vc) {
    return any_box.contains(cv::Point(uc, vc)) &&
           covered.ptr<uint8_t>(vc - any_box.y)[uc - any_box.x] != 0;
  };
  // Adds depth pixel (u, v)'s p_D to every detection whose mask covers colour pixel (uc, vc) and
  // takes it (clearOfDepthEdge).
  auto assign = [&](int uc, int vc, int u, int v, const Eigen::Vector3d& p_D) {
    if (!any_box.contains(cv::Point(uc, vc))) return;
    for (size_t i = 0; i < masks.size(); ++i) {
      if (!masks[i].box.contains(cv::Point(uc, vc))) continue;
      const MaskLookup& m = masks[i];
      if (m.mask.ptr<uint8_t>(vc - m.origin.y)[uc - m.origin.x] != 0 &&
          clearOfDepthEdge(m, u, v, p_D.z(), depthToleranceM(p_D.z(), config))) {
        (*clouds_D)[i].push_back(p_D.cast<float>());
      }
    }
  };
  const double near_px_per_m = 0.5 * K_d.fx * config.near_sampling_leaf_m;
  for (int v = 0; v < depth.rows; v += stride) {
    for (int u = 0; u < depth.cols; u += stride) {
      const double z = depthMetres(depth, u, v, config.min_valid_depth_m, config.max_valid_depth_m);
      if (!std::isfinite(z)) continue;
      if (!onNearSamplingGrid(u, v, z, near_px_per_m)) continue;
      const Eigen::Vector3d p_D((u - K_d.cx) * z / K_d.fx, (v - K_d.cy) * z / K_d.fy, z);
      cv::Point pixel;
      // Behind the colour camera or outside its image: in no mask.
      if (colorPixelOf(frame, p_D, &pixel) && inSomeMask(pixel.x, pixel.y) &&
          consistentDepth(depth, u, v, z, config)) {
        assign(pixel.x, pixel.y, u, v, p_D);
      }
    }
  }
}

}  // namespace

Status ObjectCloudExtractor::extract(const RgbdFrame& frame,
                                     const std::vector<Detection2D>& detections,
                                     std::vector<PointCloud>* clouds_D) const {
  if (clouds_D == nullptr) return Status::Error("extract: clouds_D is null");
  clouds_D->clear();
  const Status config_valid = config_.isValid();
  if (!config_valid) return Status::Error("extractor config: " + config_valid.message());
  const Status frame_valid = frame.validate();
  if (!frame_valid) return frame_valid;
  const std::string label =
      frame.name.empty() ? "frame " + std::to_string(frame.index) : frame.name;
  std::vector<MaskLookup> masks;
  const Status prepared = prepareMasks(frame, detections, config_, label, &masks);
  if (!prepared) return prepared;
  clouds_D->assign(detections.size(), PointCloud());
  cv::Rect any_box;  // union of all mask boxes
  for (const MaskLookup& m : masks) any_box |= m.box;
  if (any_box.empty()) return Status::Ok();
  const cv::Mat covered = coveredByMasks(masks, any_box);
  std::map<int, cv::Mat> near_edge_by_margin;
  // A registered frame looks depth up only inside the boxes; the margin's window reaches past them
  // (erode's border: no edge beyond the region, which only drops edges the window cannot use).
  const cv::Rect depth_rect(0, 0, frame.depth.cols, frame.depth.rows);
  const int reach_px = config_.max_depth_edge_margin_px;
  const cv::Rect near_edge_region =
      frame.registered ? cv::Rect(any_box.x - reach_px, any_box.y - reach_px,
                                  any_box.width + 2 * reach_px, any_box.height + 2 * reach_px) &
                             depth_rect
                       : depth_rect;
  attachNearEdges(frame.depth, near_edge_region, config_, &masks, &near_edge_by_margin);
  if (frame.registered) {
    extractRegistered(frame, masks, any_box, covered, config_, clouds_D);
  } else {
    extractUnregistered(frame, masks, any_box, covered, config_, clouds_D);
  }
  return Status::Ok();
}

}  // namespace mvod
