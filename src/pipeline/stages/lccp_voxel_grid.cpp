#include "lccp_voxel_grid.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "multiview_object_detection/pipeline/utils/parallel.h"
#include "multiview_object_detection/pipeline/utils/point_moments.h"
#include "multiview_object_detection/pipeline/utils/radix_sort.h"

namespace mvod {
namespace lccp_grid {
namespace {

// The plane normal of a multiset: the covariance's eigenvector of the smallest eigenvalue; zero
// when the points do not span a plane's worth of directions (one point, repeated).
Eigen::Vector3f planeNormal(const PointMoments& moments) {
  const Eigen::Matrix3d covariance = moments.covariance();
  if (!(covariance.trace() > 1e-12)) return Eigen::Vector3f::Zero();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(covariance);
  return solver.eigenvectors().col(0).normalized().cast<float>();
}

// The cloud's points on the grid of `resolution` (in the log-depth space when log_transform):
// the cloud's bounds centred in a power-of-two box of voxels.
Status voxelKeys(const PointCloud& points, bool log_transform, double resolution,
                 std::vector<std::pair<std::uint64_t, int>>* keyed) {
  const auto transformed = [log_transform](const Eigen::Vector3f& p) {
    return log_transform ? Eigen::Vector3f(p.x() / p.z(), p.y() / p.z(), std::log(p.z())) : p;
  };
  Eigen::Vector3d lower = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d upper = -lower;
  std::vector<char> usable(points.size(), 0);
  std::vector<Eigen::Vector3f> transformed_points(points.size());  // each transformed once
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite() || (log_transform && !(points[i].z() > 0.0f))) continue;
    transformed_points[i] = transformed(points[i]);
    const Eigen::Vector3d q = transformed_points[i].cast<double>();
    if (!q.allFinite()) continue;
    usable[i] = 1;
    lower = lower.cwiseMin(q);
    upper = upper.cwiseMax(q);
  }
  if (!lower.allFinite()) return Status::Error("no finite points to cluster");
  if (((upper - lower) / resolution).maxCoeff() >= static_cast<double>(kKeyMax)) {
    return Status::Error("cloud extent too large for voxel_resolution_m " +
                         std::to_string(resolution));
  }
  lower = centredOctreeOrigin(lower, upper, resolution);
  keyed->reserve(points.size());  // (Morton code, point)
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!usable[i]) continue;
    const Eigen::Vector3d cell =
        ((transformed_points[i].cast<double>() - lower) / resolution).array().floor();
    keyed->emplace_back(
        morton(static_cast<std::int64_t>(cell.x()), static_cast<std::int64_t>(cell.y()),
               static_cast<std::int64_t>(cell.z())),
        static_cast<int>(i));
  }
  radixSortByKey(keyed);
  return Status::Ok();
}

}  // namespace

// The origin of an octree of leaf size `resolution` over [lower, upper] whose bounds are given
// up front: the bounds centred in a cube of a power-of-two number of leaves (PCL's rule).
Eigen::Vector3d centredOctreeOrigin(const Eigen::Vector3d& lower, const Eigen::Vector3d& upper,
                                    double resolution) {
  const double epsilon = std::numeric_limits<float>::epsilon();
  double max_keys = 2.0;
  for (int axis = 0; axis < 3; ++axis) {
    max_keys = std::max(max_keys, std::ceil((upper[axis] - lower[axis] - epsilon) / resolution));
  }
  const int depth = static_cast<int>(std::ceil(std::log2(max_keys) - epsilon));
  const double side = static_cast<double>(std::int64_t{1} << depth) * resolution;
  Eigen::Vector3d origin = lower;
  for (int axis = 0; axis < 3; ++axis) {
    const double oversize = (side - (upper[axis] - lower[axis])) / 2.0;
    if (oversize > epsilon) origin[axis] -= oversize;
  }
  return origin;
}

// The origin of an octree of leaf size `resolution` that grows to take points one at a time: it
// starts as two leaves around the first point and doubles towards each point outside (PCL's rule).
// Only the origin's lattice and the resulting order of cells matter here.
Eigen::Vector3d growingOctreeOrigin(const std::vector<Eigen::Vector3f>& points, double resolution) {
  const double epsilon = std::numeric_limits<float>::epsilon();
  Eigen::Vector3d lower = points.front().cast<double>() - Eigen::Vector3d::Constant(resolution);
  Eigen::Vector3d upper = points.front().cast<double>() + Eigen::Vector3d::Constant(resolution);
  int depth = 1;
  for (const Eigen::Vector3f& p : points) {
    for (;;) {
      bool outside = false;
      Eigen::Vector3i above = Eigen::Vector3i::Zero();
      for (int axis = 0; axis < 3; ++axis) {
        if (p[axis] < lower[axis]) outside = true;
        if (p[axis] >= upper[axis]) {
          outside = true;
          above[axis] = 1;
        }
      }
      if (!outside) break;
      const double side = static_cast<double>(std::int64_t{1} << depth) * resolution;
      for (int axis = 0; axis < 3; ++axis) {
        if (!above[axis]) lower[axis] -= side;
      }
      ++depth;
      upper = lower + Eigen::Vector3d::Constant(
                          static_cast<double>(std::int64_t{1} << depth) * resolution - epsilon);
    }
  }
  return lower;
}

Status buildVoxelGrid(const PointCloud& points, bool log_transform, double resolution,
                      VoxelGrid* grid) {
  std::vector<std::pair<std::uint64_t, int>> keyed;
  const Status keyed_ok = voxelKeys(points, log_transform, resolution, &keyed);
  if (!keyed_ok) return keyed_ok;
  grid->voxel_of_point.assign(points.size(), -1);
  for (std::size_t begin = 0; begin < keyed.size();) {
    std::size_t end = begin;
    Eigen::Vector3f sum = Eigen::Vector3f::Zero();  // float, in input order, as PCL's leaves
    while (end < keyed.size() && keyed[end].first == keyed[begin].first) {
      sum += points[keyed[end].second];
      grid->voxel_of_point[keyed[end].second] = static_cast<int>(grid->key.size());
      ++end;
    }
    grid->key.push_back(unMorton(keyed[begin].first));
    grid->centroid.push_back(sum / static_cast<float>(end - begin));
    begin = end;
  }
  const int num_voxels = grid->size();
  KeyIndex voxel_index(grid->key.size());
  for (int v = 0; v < num_voxels; ++v) voxel_index.insert(grid->key[v], v);
  grid->neighbour_begin.assign(num_voxels + 1, 0);
  grid->neighbours.reserve(static_cast<std::size_t>(num_voxels) * 12);
  for (int v = 0; v < num_voxels; ++v) {
    forEachNeighbourKey(grid->key[v], voxel_index,
                        [grid](int n) { grid->neighbours.push_back(n); });
    grid->neighbour_begin[v + 1] = static_cast<int>(grid->neighbours.size());
  }
  return Status::Ok();
}

// 2. Voxel normals. PCL fits each to its voxel, its neighbours and their neighbours, counted with
// multiplicity: moments(v) + sum over neighbours n of (moments(n) + neighbourhood moments(n)).
// Each voxel's moments depend on its own neighbourhood only: split over the threads (the same
// result). Turned towards the frame's origin.
std::vector<Eigen::Vector3f> voxelNormals(const VoxelGrid& grid, int threads) {
  constexpr std::size_t kMinVoxelsPerThread = 2048;
  const int num_voxels = grid.size();
  const std::size_t voxel_count = static_cast<std::size_t>(num_voxels);
  const std::vector<int>& begin = grid.neighbour_begin;
  const std::vector<int>& neighbours = grid.neighbours;
  const Eigen::Vector3d origin = grid.centroid.front().cast<double>();  // for the precision
  std::vector<PointMoments> own(num_voxels), around(num_voxels);
  for (int v = 0; v < num_voxels; ++v) own[v].add(grid.centroid[v].cast<double>() - origin);
  parallelRanges(voxel_count, threads, kMinVoxelsPerThread,
                 [&](std::size_t first, std::size_t last) {
                   for (std::size_t v = first; v < last; ++v) {
                     for (int k = begin[v]; k < begin[v + 1]; ++k)
                       around[v].add(own[neighbours[k]]);
                   }
                 });
  std::vector<Eigen::Vector3f> normal(num_voxels);
  parallelRanges(voxel_count, threads, kMinVoxelsPerThread,
                 [&](std::size_t first, std::size_t last) {
                   for (std::size_t v = first; v < last; ++v) {
                     PointMoments total = own[v];
                     for (int k = begin[v]; k < begin[v + 1]; ++k) {
                       total.add(own[neighbours[k]]);
                       total.add(around[neighbours[k]]);
                     }
                     normal[v] = planeNormal(total);
                     if (grid.centroid[v].dot(normal[v]) > 0.0f) normal[v] = -normal[v];
                   }
                 });
  return normal;
}

}  // namespace lccp_grid
}  // namespace mvod
