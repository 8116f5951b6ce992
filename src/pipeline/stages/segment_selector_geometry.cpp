#include "segment_selector_geometry.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>

#include "multiview_object_detection/pipeline/utils/voxel_key.h"

namespace mvod {
namespace segment_selector_geometry {

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

const std::vector<int>& NearSegments::at(const Eigen::Vector3f& p) {
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

// The view's points in the detection's ring; of them, per segment, those near it (*near) and those
// also within plane_distance_m of its plane (*on_plane).
int countRingPoints(const SegmentSelector::FrameView& view,
                    const SegmentSelector::DetectionMasks& masks, bool registered,
                    const std::vector<Plane>& planes, NearSegments near_segments,
                    double plane_distance_m, std::vector<int>* near, std::vector<int>* on_plane) {
  int ring_points = 0;
  forEachRingPoint(view, masks, registered, [&](std::size_t k) {
    ++ring_points;
    const Eigen::Vector3f& p = view.points_D[k];
    for (const int s : near_segments.at(p)) {
      ++(*near)[s];
      if (std::abs(planes[s].normal.dot(p.cast<double>() - planes[s].point)) <= plane_distance_m) {
        ++(*on_plane)[s];
      }
    }
  });
  return ring_points;
}

std::vector<float> ringHeights(const SegmentSelector::FrameView& view,
                               const SegmentSelector::DetectionMasks& masks, bool registered,
                               const Eigen::Vector3f& up_W) {
  std::vector<float> heights_m;
  forEachRingPoint(view, masks, registered,
                   [&](std::size_t k) { heights_m.push_back(up_W.dot(view.points_W[k])); });
  std::sort(heights_m.begin(), heights_m.end());
  return heights_m;
}

std::size_t densestBand(const std::vector<float>& heights_m, float band_m, float lowest_m,
                        float highest_m, float* mean_m) {
  std::size_t best_first = 0;
  std::size_t best_count = 0;
  std::size_t first =
      std::lower_bound(heights_m.begin(), heights_m.end(), lowest_m) - heights_m.begin();
  for (std::size_t end = first; first < heights_m.size() && heights_m[first] <= highest_m;
       ++first) {
    end = std::max(end, first);
    while (end < heights_m.size() && heights_m[end] <= heights_m[first] + band_m) ++end;
    if (end - first > best_count) {
      best_count = end - first;
      best_first = first;
    }
  }
  if (best_count == 0) return 0;
  double sum_m = 0.0;
  for (std::size_t k = best_first; k < best_first + best_count; ++k) sum_m += heights_m[k];
  *mean_m = static_cast<float>(sum_m / static_cast<double>(best_count));
  return best_count;
}

}  // namespace segment_selector_geometry
}  // namespace mvod
