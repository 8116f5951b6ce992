// The segment selector's geometry, shared by its phases (segment_selector.cpp): a segment's plane,
// its extents along horizontal directions, the segments near a point and the points of a
// detection's ring. Private to the pipeline library.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "multiview_object_detection/pipeline/stages/segment_selector.h"
#include "multiview_object_detection/pipeline/utils/flat_hash_map.h"

namespace mvod {
namespace segment_selector_geometry {

// The cells of one cloud: cell -> the segments with points in it (few per cell).
using CellSegments = FlatHashMap<std::int64_t, std::vector<int>>;

inline void addToCell(CellSegments* cells, std::int64_t key, int segment) {
  std::vector<int>& list = (*cells)[key];
  if (std::find(list.begin(), list.end(), segment) == list.end()) list.push_back(segment);
}

// A segment's plane: its normal, a point on it and the RMS distance of its points to it.
struct Plane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  double rms_m = 0.0;
};

// The least-squares plane of the points at indices; rms_m infinite under 3 points.
Plane fitPlane(const PointCloud& points, const std::vector<int>& indices);

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
                                   const std::vector<Eigen::Vector3f>& directions);

// The segments near each point of the ring: the segments with a point in one of the 27 cells of
// cell_m around it. Neighbouring pixels mostly share a cell: its 27 lookups are done once per run
// of them.
class NearSegments {
 public:
  NearSegments(const CellSegments& cells, float cell_m) : cells_(cells), cell_m_(cell_m) {}
  const std::vector<int>& at(const Eigen::Vector3f& p);

 private:
  const CellSegments& cells_;
  float cell_m_;
  std::vector<int> touched_;  // the segments near the last point's cell
  std::int64_t key_ = 0;
  bool valid_ = false;
};

// f(k) for each view point k whose colour pixel lies in the detection's ring. A registered frame's
// view points lie at their colour pixels: only the crop's rows are looked at.
template <typename F>
void forEachRingPoint(const SegmentSelector::FrameView& view,
                      const SegmentSelector::DetectionMasks& masks, bool registered, F f) {
  const cv::Rect& crop = masks.crop;
  const std::pair<std::size_t, std::size_t> range =
      registered ? view.rows(crop.y, crop.y + crop.height)
                 : std::make_pair(std::size_t{0}, view.points_D.size());
  for (std::size_t k = range.first; k < range.second; ++k) {
    const cv::Point& pixel = view.pixels_color[k];
    if (!crop.contains(pixel)) continue;
    if (masks.ring.ptr<uint8_t>(pixel.y - crop.y)[pixel.x - crop.x] == 0) continue;
    f(k);
  }
}

// The view's points in the detection's ring; of them, per segment, those near it (*near) and those
// also within plane_distance_m of its plane (*on_plane).
int countRingPoints(const SegmentSelector::FrameView& view,
                    const SegmentSelector::DetectionMasks& masks, bool registered,
                    const std::vector<Plane>& planes, NearSegments near_segments,
                    double plane_distance_m, std::vector<int>* near, std::vector<int>* on_plane);

// The heights along up_W of the view's points in the detection's ring, ascending.
std::vector<float> ringHeights(const SegmentSelector::FrameView& view,
                               const SegmentSelector::DetectionMasks& masks, bool registered,
                               const Eigen::Vector3f& up_W);

// The band of band_m of sorted heights_m, its lowest height within [lowest_m, highest_m], that
// holds the most of them: their count (0: none in range) and *mean_m, their mean.
std::size_t densestBand(const std::vector<float>& heights_m, float band_m, float lowest_m,
                        float highest_m, float* mean_m);

}  // namespace segment_selector_geometry
}  // namespace mvod
