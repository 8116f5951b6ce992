// The segment selector's inputs: the frame's view (its depth pixels in the depth and world frames),
// a detection's masks (mask, core, ring) and the segments' adjacency.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "multiview_object_detection/pipeline/stages/object_cloud_extractor.h"
#include "multiview_object_detection/pipeline/stages/segment_selector.h"
#include "multiview_object_detection/pipeline/utils/flat_hash_map.h"
#include "multiview_object_detection/pipeline/utils/morphology.h"
#include "multiview_object_detection/pipeline/utils/radix_sort.h"
#include "multiview_object_detection/pipeline/utils/voxel_key.h"

namespace mvod {

SegmentSelector::FrameView SegmentSelector::makeFrameView(const RgbdFrame& frame, int stride,
                                                          double min_depth_m, double max_depth_m) {
  FrameView view;
  const cv::Mat& depth = frame.depth;
  const CameraIntrinsics& K_d = frame.K_depth;
  if (depth.empty() || !K_d.isValid() || !frame.K_color.isValid() || stride < 1) return view;
  const int columns = (depth.cols + stride - 1) / stride;
  const std::size_t pixels = static_cast<std::size_t>((depth.rows + stride - 1) / stride) * columns;
  view.points_D.reserve(pixels);
  view.points_W.reserve(pixels);
  view.pixels_color.reserve(pixels);
  std::vector<float> row_m(columns);
  view.stride = stride;
  view.row_begin.reserve((depth.rows + stride - 1) / stride + 1);
  for (int v = 0; v < depth.rows; v += stride) {
    view.row_begin.push_back(view.points_D.size());
    ObjectCloudExtractor::depthRowAt(depth, v, 0, stride, columns, min_depth_m, max_depth_m,
                                     row_m.data());
    for (int u = 0; u < depth.cols; u += stride) {
      const float z = row_m[u / stride];
      if (!std::isfinite(z)) continue;
      const Eigen::Vector3d p_D((u - K_d.cx) * z / K_d.fx, (v - K_d.cy) * z / K_d.fy, z);
      cv::Point pixel(u, v);
      if (!frame.registered && !colorPixelOf(frame, p_D, &pixel)) pixel = cv::Point(-1, -1);
      view.points_D.push_back(p_D.cast<float>());
      view.points_W.push_back((frame.T_W_D * p_D).cast<float>());
      view.pixels_color.push_back(pixel);
    }
  }
  view.row_begin.push_back(view.points_D.size());
  return view;
}

std::pair<std::size_t, std::size_t> SegmentSelector::FrameView::rows(int first_row,
                                                                     int end_row) const {
  if (row_begin.empty() || stride < 1) return {0, points_D.size()};
  const int rows_stored = static_cast<int>(row_begin.size()) - 1;
  // Stored rows j hold depth row j * stride: the first j with j * stride >= first_row.
  const int first = std::min(rows_stored, std::max(0, (first_row + stride - 1) / stride));
  const int end = std::min(rows_stored, std::max(first, (end_row + stride - 1) / stride));
  return {row_begin[first], row_begin[end]};
}

namespace {

// Segment adjacency (adjacent[a][b]: a point of a and one of b lie in the same or neighbouring
// cells of cell_m) on a dense grid of the points' cells, each holding a bit per segment, for up to
// 64 segments over at most 2^24 cells; false (nothing done) otherwise. The cells are voxelKeyOf's,
// so the adjacency is that of the packed-key search.
bool segmentAdjacencyOnGrid(const PointCloud& points, const std::vector<std::vector<int>>& segments,
                            double cell_m, std::vector<std::vector<char>>* adjacent) {
  const int num_segments = static_cast<int>(segments.size());
  if (num_segments > 64 || num_segments == 0) return false;
  const double inv = 1.0 / cell_m;
  constexpr double kMaxCell = 1 << 20;  // voxelKeyOf's fields: no aliasing below this
  Eigen::Array3i lo = Eigen::Array3i::Constant(std::numeric_limits<int>::max());
  Eigen::Array3i hi = Eigen::Array3i::Constant(std::numeric_limits<int>::min());
  std::vector<Eigen::Array3i> cells;  // per point of the segments, in segment order
  for (const std::vector<int>& segment : segments) {
    for (const int i : segment) {
      const Eigen::Vector3f& p = points[i];
      Eigen::Array3i c;
      for (int d = 0; d < 3; ++d) {
        const double index = std::floor(p[d] * inv);
        if (!(std::abs(index) < kMaxCell)) return false;
        c[d] = static_cast<int>(index);
      }
      lo = lo.min(c);
      hi = hi.max(c);
      cells.push_back(c);
    }
  }
  if (cells.empty()) return false;
  const Eigen::Array3i dims = hi - lo + 3;  // a margin of one cell for the neighbours
  if (!(static_cast<double>(dims[0]) * dims[1] * dims[2] <= 16.0 * 1024 * 1024)) return false;
  const std::int64_t stride_y = dims[0];
  const std::int64_t stride_z = static_cast<std::int64_t>(dims[0]) * dims[1];
  std::vector<std::uint64_t> grid(static_cast<std::size_t>(stride_z) * dims[2], 0);
  std::vector<std::int64_t> occupied;
  std::size_t k = 0;
  for (int s = 0; s < num_segments; ++s) {
    for (std::size_t n = 0; n < segments[s].size(); ++n, ++k) {
      const Eigen::Array3i r = cells[k] - lo + 1;
      const std::int64_t cell = r[2] * stride_z + r[1] * stride_y + r[0];
      if (grid[cell] == 0) occupied.push_back(cell);
      grid[cell] |= std::uint64_t{1} << s;
    }
  }
  std::vector<std::uint64_t> touching(num_segments, 0);
  for (const std::int64_t cell : occupied) {
    std::uint64_t around = 0;
    for (int dz = -1; dz <= 1; ++dz) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) around |= grid[cell + dz * stride_z + dy * stride_y + dx];
      }
    }
    for (std::uint64_t here = grid[cell]; here != 0; here &= here - 1) {
      int a = 0;
      while (((here >> a) & 1u) == 0) ++a;
      touching[a] |= around;
    }
  }
  for (int a = 0; a < num_segments; ++a) {
    for (int b = 0; b < num_segments; ++b) (*adjacent)[a][b] = (touching[a] >> b) & 1u;
  }
  return true;
}

}  // namespace

std::vector<std::vector<char>> SegmentSelector::segmentAdjacency(
    const PointCloud& points, const std::vector<std::vector<int>>& segments, double cell_m) {
  const int num_segments = static_cast<int>(segments.size());
  std::vector<std::vector<char>> adjacent(num_segments, std::vector<char>(num_segments, 0));
  if (segmentAdjacencyOnGrid(points, segments, cell_m, &adjacent)) return adjacent;
  // The (cell, segment) pairs radix-sorted and made unique (packed keys are non-negative, so
  // their order as unsigned is theirs); each occupied cell is then a range of segments, found by
  // key.
  std::vector<std::pair<std::uint64_t, int>> cell_segment;
  cell_segment.reserve(points.size());
  for (int s = 0; s < num_segments; ++s) {
    for (const int i : segments[s]) {
      cell_segment.emplace_back(static_cast<std::uint64_t>(voxelKeyOf(points[i], cell_m)), s);
    }
  }
  radixSortByKey(&cell_segment);  // stable: a cell's segments stay in ascending order
  cell_segment.erase(std::unique(cell_segment.begin(), cell_segment.end()), cell_segment.end());
  std::vector<std::size_t> cell_begin;
  FlatHashMap<std::uint64_t, int> cell_of_key;  // key -> index into cell_begin
  for (std::size_t k = 0; k < cell_segment.size(); ++k) {
    if (k == 0 || cell_segment[k].first != cell_segment[k - 1].first) {
      cell_of_key[cell_segment[k].first] = static_cast<int>(cell_begin.size());
      cell_begin.push_back(k);
    }
  }
  cell_begin.push_back(cell_segment.size());
  for (std::size_t c = 0; c + 1 < cell_begin.size(); ++c) {
    const std::int64_t key = static_cast<std::int64_t>(cell_segment[cell_begin[c]].first);
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it =
              cell_of_key.find(static_cast<std::uint64_t>(offsetVoxelKey(key, dx, dy, dz)));
          if (it == cell_of_key.end()) continue;
          const std::size_t d = static_cast<std::size_t>(it->second);
          for (std::size_t a = cell_begin[c]; a < cell_begin[c + 1]; ++a) {
            for (std::size_t b = cell_begin[d]; b < cell_begin[d + 1]; ++b) {
              adjacent[cell_segment[a].second][cell_segment[b].second] = 1;
            }
          }
        }
      }
    }
  }
  return adjacent;
}

SegmentSelector::DetectionMasks SegmentSelector::detectionMasks(const Detection2D& detection,
                                                                const cv::Size& image_size) const {
  DetectionMasks masks;
  const cv::Rect image_rect(cv::Point(0, 0), image_size);
  const cv::Rect box = detection.box_px & image_rect;
  if (box.empty()) {
    masks.status = Status::Error("the detection's box lies outside the image");
    return masks;
  }
  if (box.area() > config_.max_box_image_fraction * image_rect.area()) {
    masks.status = Status::Error("the box covers the whole image (" +
                                 std::to_string(100 * box.area() / image_rect.area()) +
                                 " %): no background to cut the object from");
    return masks;
  }
  const int ring = config_.ring_px;
  const cv::Rect crop = cv::Rect(box.x - ring - 1, box.y - ring - 1, box.width + 2 * ring + 2,
                                 box.height + 2 * ring + 2) &
                        image_rect;
  masks.crop = crop;
  cv::Mat mask(crop.size(), CV_8UC1, cv::Scalar(0));
  const cv::Rect box_in_crop = box - crop.tl();
  bool box_only = true;
  cv::Point origin;
  if (maskOrigin(detection, image_size, &origin)) {
    mask = maskInRegion(detection, image_size, crop);
    const int filled = cv::countNonZero(mask(box_in_crop));
    box_only = filled >= 0.97 * box.area();
  } else {
    mask(box_in_crop).setTo(255);
  }
  cv::Mat core(crop.size(), CV_8UC1, cv::Scalar(0));
  if (box_only) {
    const double f = config_.core_box_fraction;
    const int w = std::max(1, static_cast<int>(std::lround(f * box.width)));
    const int h = std::max(1, static_cast<int>(std::lround(f * box.height)));
    core(cv::Rect(box_in_crop.x + (box.width - w) / 2, box_in_crop.y + (box.height - h) / 2, w, h))
        .setTo(255);
  } else {
    const int radius =
        static_cast<int>(config_.core_mask_erosion * std::min(box.width, box.height));
    // An elliptic kernel of up to ~50 px: OpenCV's erode costs O(pixels x radius²) there.
    if (radius > 0) erodeWithEllipse(mask, radius, &core);
    if (cv::countNonZero(core) == 0) core = mask.clone();
  }
  cv::Mat ring_mask;
  cv::dilate(mask, ring_mask,
             cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * ring + 1, 2 * ring + 1)));
  ring_mask.setTo(0, mask);
  masks.mask = mask;
  masks.core = core;
  masks.ring = ring_mask;
  return masks;
}

}  // namespace mvod
