// Surface normals of a cloud, Eq. 3's input (Sec. 3.3): PCA over the neighbours within a radius
// (PCL's normal estimation, the paper's), or from the summed moments of cells.
#pragma once

#include <limits>
#include <vector>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {

// "No normal estimated here".
inline Eigen::Vector3f nanNormal() {
  return Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
}

// Surface normals by PCA over neighbours within radius_m (at most max_neighbours); unit length,
// oriented arbitrarily. Points with fewer than 3 neighbours get a NaN normal.
std::vector<Eigen::Vector3f> estimateNormals(const PointCloud& points, double radius_m,
                                             int max_neighbours = 30);

// The same at points[queries[i]] only (normals[i]), with the whole cloud as neighbours: for a
// caller that needs normals at a subsample. threads: the queries split over this many threads
// (each query is independent: the same result).
std::vector<Eigen::Vector3f> estimateNormalsAt(const PointCloud& points,
                                               const std::vector<int>& queries, double radius_m,
                                               int max_neighbours, int threads = 1);

// Normals at points[queries[i]] from cell moments: cells of half the radius, and for a query the
// summed moments of the cells whose centres lie within the radius of its cell's centre (33 cells),
// PCA as in estimateNormalsAt. Queries in one cell share its normal, so the cost is that of the
// occupied cells, whatever the radius. threads: the occupied cells split over this many threads
// (each cell's normal is independent: the same result).
std::vector<Eigen::Vector3f> estimateCellNormalsAt(const PointCloud& points,
                                                   const std::vector<int>& queries, double radius_m,
                                                   int threads = 1);

}  // namespace mvod
