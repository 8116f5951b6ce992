#include "multiview_object_detection/pipeline/segment_selector.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <unordered_map>

#include "multiview_object_detection/pipeline/object_cloud_extractor.h"
#include "multiview_object_detection/pipeline/voxel_key.h"

namespace mvod {
namespace {

constexpr double kPiOver18 = 3.14159265358979323846 / 18.0;

// The cells of one cloud: cell -> the segments with points in it (few per cell).
using CellSegments = std::unordered_map<std::int64_t, std::vector<int>>;

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
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const int i : indices) {
    const Eigen::Vector3d d = points[i].cast<double>() - mean;
    covariance += d * d.transpose();
  }
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
  if (!(std::isfinite(prior_size_slack) && prior_size_slack >= 1.0)) {
    return Status::Error("prior_size_slack must be >= 1");
  }
  if (!(max_box_image_fraction > 0.0 && max_box_image_fraction <= 1.0)) {
    return Status::Error("max_box_image_fraction must be in (0, 1]");
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
      << "prior_size_slack: " << prior_size_slack << "\n"
      << "max_box_image_fraction: " << max_box_image_fraction << "\n";
  return out.str();
}

SegmentSelector::FrameView SegmentSelector::makeFrameView(const RgbdFrame& frame, int stride,
                                                          double min_depth_m, double max_depth_m) {
  FrameView view;
  const cv::Mat& depth = frame.depth;
  const CameraIntrinsics& K_d = frame.K_depth;
  if (depth.empty() || !K_d.isValid() || !frame.K_color.isValid() || stride < 1) return view;
  for (int v = 0; v < depth.rows; v += stride) {
    for (int u = 0; u < depth.cols; u += stride) {
      const float z = ObjectCloudExtractor::depthAt(depth, u, v, min_depth_m, max_depth_m);
      if (!std::isfinite(z)) continue;
      const Eigen::Vector3d p_D((u - K_d.cx) * z / K_d.fx, (v - K_d.cy) * z / K_d.fy, z);
      cv::Point pixel(u, v);
      if (!frame.registered && !colorPixelOf(frame, p_D, &pixel)) pixel = cv::Point(-1, -1);
      view.points_D.push_back(p_D.cast<float>());
      view.points_W.push_back((frame.T_W_D * p_D).cast<float>());
      view.pixels_color.push_back(pixel);
    }
  }
  return view;
}

Status SegmentSelector::select(const Input& input, Result* result) const {
  if (result == nullptr || input.points_D == nullptr || input.segments == nullptr) {
    return Status::Error("SegmentSelector::select: missing input");
  }
  *result = Result();
  const PointCloud& points = *input.points_D;
  const std::vector<std::vector<int>>& segments = *input.segments;
  if (segments.empty() || segments[0].empty()) return Status::Error("no segment to select");
  if (!config_.consistent() || input.detection == nullptr || input.frame == nullptr) {
    // Eq. 2: the largest segment.
    result->indices = segments[0];
    std::sort(result->indices.begin(), result->indices.end());
    result->kept_segments = 1;
    return Status::Ok();
  }
  const Detection2D& detection = *input.detection;
  const RgbdFrame& frame = *input.frame;
  const cv::Size image_size = frame.color_bgr.size();
  const cv::Rect image_rect(cv::Point(0, 0), image_size);

  // ---- The detection in colour pixels: its mask (a box-only detection fills its box), its core
  // and the ring just outside it, all on a crop around the box.
  const cv::Rect box = detection.box_px & image_rect;
  if (box.empty()) return Status::Error("the detection's box lies outside the image");
  if (box.area() > config_.max_box_image_fraction * image_rect.area()) {
    return Status::Error("the box covers the whole image (" +
                         std::to_string(100 * box.area() / image_rect.area()) +
                         " %): no background to cut the object from");
  }
  const int ring = config_.ring_px;
  const cv::Rect crop = cv::Rect(box.x - ring - 1, box.y - ring - 1, box.width + 2 * ring + 2,
                                 box.height + 2 * ring + 2) &
                        image_rect;
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
    if (radius > 0) {
      const cv::Mat kernel =
          cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * radius + 1, 2 * radius + 1));
      cv::erode(mask, core, kernel);
    }
    if (cv::countNonZero(core) == 0) core = mask.clone();
  }
  cv::Mat ring_mask;
  cv::dilate(mask, ring_mask,
             cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * ring + 1, 2 * ring + 1)));
  ring_mask.setTo(0, mask);

  // ---- Per point: in the core? World coordinates for the size limit.
  std::vector<char> in_core(points.size(), 0);
  for (size_t i = 0; i < points.size(); ++i) {
    cv::Point pixel;
    if (colorPixelOf(frame, points[i].cast<double>(), &pixel) && crop.contains(pixel)) {
      in_core[i] = core.ptr<uint8_t>(pixel.y - crop.y)[pixel.x - crop.x] != 0;
    }
  }

  const int num_segments = static_cast<int>(segments.size());
  std::vector<int> core_count(num_segments, 0);
  for (int s = 0; s < num_segments; ++s) {
    for (const int i : segments[s]) core_count[s] += in_core[i];
  }

  // ---- Bounding surfaces: planar segments that continue in the ring outside the detection.
  std::vector<char> bounding(num_segments, 0);
  if (input.view != nullptr) {
    std::vector<Plane> planes(num_segments);
    const float near_cell_m = 0.05f;  // "near a segment": within one 5 cm cell of its points
    CellSegments near_cells;
    for (int s = 0; s < num_segments; ++s) {
      if (segments[s].size() < 20) continue;
      planes[s] = fitPlane(points, segments[s]);
      if (planes[s].rms_m > config_.plane_max_thickness_m) continue;
      for (const int i : segments[s]) addToCell(&near_cells, voxelKeyOf(points[i], near_cell_m), s);
    }
    if (!near_cells.empty()) {
      std::vector<int> near(num_segments, 0);
      std::vector<int> on_plane(num_segments, 0);
      std::vector<int> touched;
      const FrameView& view = *input.view;
      for (size_t k = 0; k < view.points_D.size(); ++k) {
        const cv::Point& pixel = view.pixels_color[k];
        if (!crop.contains(pixel)) continue;
        if (ring_mask.ptr<uint8_t>(pixel.y - crop.y)[pixel.x - crop.x] == 0) continue;
        const Eigen::Vector3f& p = view.points_D[k];
        const std::int64_t key = voxelKeyOf(p, near_cell_m);
        touched.clear();
        for (int dx = -1; dx <= 1; ++dx) {
          for (int dy = -1; dy <= 1; ++dy) {
            for (int dz = -1; dz <= 1; ++dz) {
              const auto it = near_cells.find(offsetVoxelKey(key, dx, dy, dz));
              if (it == near_cells.end()) continue;
              for (const int s : it->second) {
                if (std::find(touched.begin(), touched.end(), s) == touched.end()) {
                  touched.push_back(s);
                }
              }
            }
          }
        }
        for (const int s : touched) {
          ++near[s];
          if (std::abs(planes[s].normal.dot(p.cast<double>() - planes[s].point)) <=
              config_.plane_distance_m) {
            ++on_plane[s];
          }
        }
      }
      for (int s = 0; s < num_segments; ++s) {
        bounding[s] = on_plane[s] >= config_.min_continuation_points &&
                      on_plane[s] >= config_.min_continuation * near[s];
        result->bounding_segments += bounding[s];
      }
    }
  }

  // ---- The seed: the most points in the core.
  int seed = -1;
  for (int s = 0; s < num_segments; ++s) {
    if (bounding[s] || core_count[s] == 0) continue;
    if (seed < 0 || core_count[s] > core_count[seed]) seed = s;
  }
  if (seed < 0) {
    return Status::Error(
        result->bounding_segments > 0
            ? "only surfaces running past the detection (wall, floor, table top) in its core"
            : "no segment in the detection's core");
  }

  // ---- Adjacency between segments: points within adjacency_distance_m (neighbouring cells).
  CellSegments cells;
  for (int s = 0; s < num_segments; ++s) {
    for (const int i : segments[s])
      addToCell(&cells, voxelKeyOf(points[i], config_.adjacency_distance_m), s);
  }
  std::vector<std::vector<char>> adjacent(num_segments, std::vector<char>(num_segments, 0));
  for (const auto& cell : cells) {
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = cells.find(offsetVoxelKey(cell.first, dx, dy, dz));
          if (it == cells.end()) continue;
          for (const int a : cell.second) {
            for (const int b : it->second) adjacent[a][b] = 1;
          }
        }
      }
    }
  }

  // ---- Grow from the seed: touching segments join while the union stays plausible in size.
  const Eigen::Isometry3f T_W_D = frame.T_W_D.cast<float>();
  const Eigen::Vector3f up = input.gravity.up.cast<float>();
  const Eigen::Vector3f x_h = input.gravity.x_h.cast<float>();
  const Eigen::Vector3f y_h = input.gravity.y_h.cast<float>();
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
  std::vector<Eigen::Vector3f> directions;
  for (int k = 0; k < kDirections; ++k) {
    const float a = static_cast<float>(k * kPiOver18);
    directions.push_back(std::cos(a) * x_h + std::sin(a) * y_h);
  }
  directions.push_back(up);
  std::vector<Extent> extents(num_segments);
  for (int s = 0; s < num_segments; ++s) {
    for (const int i : segments[s]) {
      const Eigen::Vector3f p_W = T_W_D * points[i];
      for (int k = 0; k <= kDirections; ++k) {
        const float q = directions[k].dot(p_W);
        extents[s].lower[k] = std::min(extents[s].lower[k], q);
        extents[s].upper[k] = std::max(extents[s].upper[k], q);
      }
    }
  }
  double max_height_m = std::numeric_limits<double>::infinity();
  double max_short_m = std::numeric_limits<double>::infinity();
  double max_long_m = std::numeric_limits<double>::infinity();
  if (input.prior != nullptr && input.prior->has_size) {
    const Eigen::Vector3d& size = input.prior->size_m;
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

  std::vector<char> kept(num_segments, 0);
  kept[seed] = 1;
  Extent kept_extent = extents[seed];
  size_t kept_points = segments[seed].size();
  for (bool grew = true; grew;) {
    grew = false;
    // Best candidate first: the most core points, then the largest.
    int best = -1;
    for (int s = 0; s < num_segments; ++s) {
      if (kept[s] || bounding[s]) continue;
      bool touches = false;
      for (int t = 0; t < num_segments && !touches; ++t) touches = kept[t] && adjacent[s][t];
      if (!touches) continue;
      // A large segment with nothing in the core is background the detection only grazes.
      if (core_count[s] == 0 && segments[s].size() > kept_points) continue;
      Extent grown = kept_extent;
      grown.add(extents[s]);
      if (!plausible(grown)) continue;
      if (best < 0 || core_count[s] > core_count[best] ||
          (core_count[s] == core_count[best] && segments[s].size() > segments[best].size())) {
        best = s;
      }
    }
    if (best >= 0) {
      kept[best] = 1;
      kept_extent.add(extents[best]);
      kept_points += segments[best].size();
      grew = true;
    }
  }
  for (int s = 0; s < num_segments; ++s) {
    if (!kept[s]) continue;
    ++result->kept_segments;
    result->indices.insert(result->indices.end(), segments[s].begin(), segments[s].end());
  }
  std::sort(result->indices.begin(), result->indices.end());
  return Status::Ok();
}

}  // namespace mvod
