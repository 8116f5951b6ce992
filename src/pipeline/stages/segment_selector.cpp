#include "multiview_object_detection/pipeline/stages/segment_selector.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "multiview_object_detection/pipeline/stages/object_cloud_extractor.h"
#include "multiview_object_detection/pipeline/utils/flat_hash_map.h"
#include "multiview_object_detection/pipeline/utils/morphology.h"
#include "multiview_object_detection/pipeline/utils/radix_sort.h"
#include "multiview_object_detection/pipeline/utils/voxel_key.h"

namespace mvod {
namespace {

constexpr double kPiOver18 = 3.14159265358979323846 / 18.0;
constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

// The cells of one cloud: cell -> the segments with points in it (few per cell).
using CellSegments = FlatHashMap<std::int64_t, std::vector<int>>;

void addToCell(CellSegments* cells, std::int64_t key, int segment) {
  std::vector<int>& list = (*cells)[key];
  if (std::find(list.begin(), list.end(), segment) == list.end()) list.push_back(segment);
}

struct Plane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  double rms_m = 0.0;
};

Plane fitPlane(const PointCloud& points, const std::vector<int>& indices) {
  Plane plane;
  if (indices.size() < 3) {
    plane.rms_m = std::numeric_limits<double>::infinity();
    return plane;
  }
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const int i : indices) mean += points[i].cast<double>();
  mean /= static_cast<double>(indices.size());
  // The six distinct moments in scalars: the same sums, in the same order, as adding d d^T.
  double xx = 0.0, xy = 0.0, xz = 0.0, yy = 0.0, yz = 0.0, zz = 0.0;
  for (const int i : indices) {
    const Eigen::Vector3d d = points[i].cast<double>() - mean;
    xx += d.x() * d.x();
    xy += d.x() * d.y();
    xz += d.x() * d.z();
    yy += d.y() * d.y();
    yz += d.y() * d.z();
    zz += d.z() * d.z();
  }
  Eigen::Matrix3d covariance;
  covariance << xx, xy, xz, xy, yy, yz, xz, yz, zz;
  covariance /= static_cast<double>(indices.size());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
  plane.normal = solver.eigenvectors().col(0);
  plane.point = mean;
  plane.rms_m = std::sqrt(std::max(0.0, solver.eigenvalues()(0)));
  return plane;
}

}  // namespace

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

namespace {

// Extents along 18 horizontal directions (every 10 degrees) and up: unions are min/max per
// direction, and the narrowest direction with its perpendicular approximates the footprint
// rectangle whatever the object's yaw.
constexpr int kDirections = 18;
struct Extent {
  Eigen::Array<float, kDirections + 1, 1> lower =
      Eigen::Array<float, kDirections + 1, 1>::Constant(std::numeric_limits<float>::infinity());
  Eigen::Array<float, kDirections + 1, 1> upper = -lower;
  void add(const Extent& other) {
    lower = lower.min(other.lower);
    upper = upper.max(other.upper);
  }
};

// The segments' extents along `directions` (kDirections + 1 of them). Four directions at a time (a
// fifth group holds the 19th and a zero direction): per lane the same float operations as
// directions[k].dot(p_W) (Eigen's order, x + (y + z)), std::min and std::max, so the same extents
// to the bit.
std::vector<Extent> segmentExtents(const PointCloud& points_W,
                                   const std::vector<std::vector<int>>& segments,
                                   const std::vector<Eigen::Vector3f>& directions) {
  typedef float Lanes __attribute__((vector_size(16)));
  constexpr int kGroups = (kDirections + 1 + 3) / 4;
  Lanes dx[kGroups], dy[kGroups], dz[kGroups];
  for (int g = 0; g < kGroups; ++g) {
    for (int l = 0; l < 4; ++l) {
      const int k = 4 * g + l;
      const Eigen::Vector3f d = k <= kDirections ? directions[k] : Eigen::Vector3f::Zero();
      dx[g][l] = d.x();
      dy[g][l] = d.y();
      dz[g][l] = d.z();
    }
  }
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<Extent> extents(segments.size());
  for (std::size_t s = 0; s < segments.size(); ++s) {
    Lanes lower[kGroups], upper[kGroups];
    for (int g = 0; g < kGroups; ++g) {
      lower[g] = Lanes{inf, inf, inf, inf};
      upper[g] = -lower[g];
    }
    for (const int i : segments[s]) {
      const Eigen::Vector3f& p_W = points_W[i];
      const float x = p_W.x();
      const float y = p_W.y();
      const float z = p_W.z();
      for (int g = 0; g < kGroups; ++g) {
        const Lanes q = dx[g] * x + (dy[g] * y + dz[g] * z);
        lower[g] = q < lower[g] ? q : lower[g];
        upper[g] = upper[g] < q ? q : upper[g];
      }
    }
    for (int k = 0; k <= kDirections; ++k) {
      extents[s].lower[k] = lower[k / 4][k % 4];
      extents[s].upper[k] = upper[k / 4][k % 4];
    }
  }
  return extents;
}

// The segments near each point of the ring: the segments with a point in one of the 27 cells of
// cell_m around it. Neighbouring pixels mostly share a cell: its 27 lookups are done once per run
// of them.
class NearSegments {
 public:
  NearSegments(const CellSegments& cells, float cell_m) : cells_(cells), cell_m_(cell_m) {}
  const std::vector<int>& at(const Eigen::Vector3f& p) {
    const std::int64_t key = voxelKeyOf(p, cell_m_);
    if (valid_ && key == key_) return touched_;
    valid_ = true;
    key_ = key;
    touched_.clear();
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = cells_.find(offsetVoxelKey(key, dx, dy, dz));
          if (it == cells_.end()) continue;
          for (const int s : it->second) {
            if (std::find(touched_.begin(), touched_.end(), s) == touched_.end()) {
              touched_.push_back(s);
            }
          }
        }
      }
    }
    return touched_;
  }

 private:
  const CellSegments& cells_;
  float cell_m_;
  std::vector<int> touched_;  // the segments near the last point's cell
  std::int64_t key_ = 0;
  bool valid_ = false;
};

// The view's points in the detection's ring; of them, per segment, those near it (*near) and those
// also within plane_distance_m of its plane (*on_plane).
int countRingPoints(const SegmentSelector::FrameView& view,
                    const SegmentSelector::DetectionMasks& masks, bool registered,
                    const std::vector<Plane>& planes, NearSegments near_segments,
                    double plane_distance_m, std::vector<int>* near, std::vector<int>* on_plane) {
  const cv::Rect& crop = masks.crop;
  const cv::Mat& ring_mask = masks.ring;
  int ring_points = 0;
  // A registered frame's view points lie at their colour pixels: only the crop's rows.
  const std::pair<std::size_t, std::size_t> range =
      registered ? view.rows(crop.y, crop.y + crop.height)
                 : std::make_pair(std::size_t{0}, view.points_D.size());
  for (size_t k = range.first; k < range.second; ++k) {
    const cv::Point& pixel = view.pixels_color[k];
    if (!crop.contains(pixel)) continue;
    if (ring_mask.ptr<uint8_t>(pixel.y - crop.y)[pixel.x - crop.x] == 0) continue;
    ++ring_points;
    const Eigen::Vector3f& p = view.points_D[k];
    for (const int s : near_segments.at(p)) {
      ++(*near)[s];
      if (std::abs(planes[s].normal.dot(p.cast<double>() - planes[s].point)) <= plane_distance_m) {
        ++(*on_plane)[s];
      }
    }
  }
  return ring_points;
}

}  // namespace

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
        on_floor(in.prior != nullptr && in.prior->on_floor),
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
  const bool on_floor;
  std::vector<int> core_count;  // per segment: its points in the detection's core
  std::vector<Plane> planes;    // per segment; rms_m infinite: under 20 points, no plane
  std::vector<char> bounding;   // walls, surfaces running past the detection
  std::vector<char> resting;    // standing on a horizontal bounding surface (on_floor classes)
  PointCloud points_W;          // the points in the world frame
  std::vector<Extent> extents;  // per segment, in the gravity frame
  int seed = -1;
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
  std::vector<char> in_core(points.size(), 0);
  for (size_t i = 0; i < points.size(); ++i) {
    cv::Point pixel;
    if (colorPixelOf(work->frame, points[i].cast<double>(), &pixel) && crop.contains(pixel)) {
      in_core[i] = core.ptr<uint8_t>(pixel.y - crop.y)[pixel.x - crop.x] != 0;
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
    const bool support =
        !work->on_floor && work->horizontal(s, config_.plane_max_thickness_m, &n, &p);
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
  // The kept points marked, then collected in ascending order (segments do not share points).
  std::vector<char> take(work.points.size(), 0);
  std::size_t taken = 0;
  std::vector<char> dropped;  // above the top, or beside it
  for (int s = 0; s < work.num_segments; ++s) {
    if (!work.kept[s]) continue;
    dropped.assign(segments[s].size(), 0);
    size_t num_above = 0;
    if (has_top) {
      for (size_t k = 0; k < segments[s].size(); ++k) {
        const Eigen::Vector3f& p_W = work.points_W[segments[s][k]];
        const bool above = top_normal_W.dot(p_W - top_point_W) > top_clearance_m;
        num_above += above;
        dropped[k] = above || outside_top(p_W);
      }
    }
    if (num_above > 0 && num_above >= config_.top_crossing_share * segments[s].size()) {
      result->above_top_points += static_cast<int>(segments[s].size());  // rises through the top
      continue;
    }
    ++result->kept_segments;
    for (size_t k = 0; k < segments[s].size(); ++k) {
      if (dropped[k]) {
        ++result->above_top_points;
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
