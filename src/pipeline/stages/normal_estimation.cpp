// Surface normals by PCA (Eq. 3's input): over the neighbours within a radius per query point, or
// from the summed moments of the cells around the query's cell.
#include "multiview_object_detection/pipeline/stages/normal_estimation.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <utility>

#include "multiview_object_detection/pipeline/utils/flat_hash_map.h"
#include "multiview_object_detection/pipeline/utils/parallel.h"
#include "multiview_object_detection/pipeline/utils/point_moments.h"
#include "multiview_object_detection/pipeline/utils/radix_sort.h"

namespace mvod {
namespace {

// Neighbour search: a hash grid with cells of the search radius, so a radius query visits 27 cells.
// Points are stored sorted by cell for cache locality. Cell keys may collide for huge extents;
// colliding cells are merged, which only adds candidates (every candidate is distance-checked).
class VoxelNeighbourSearch {
 public:
  VoxelNeighbourSearch(const PointCloud& points, double radius_m)
      : inv_cell_(1.0 / radius_m), radius_sq_(static_cast<float>(radius_m * radius_m)) {
    std::vector<std::pair<uint64_t, int>> keyed;
    keyed.reserve(points.size());
    for (size_t i = 0; i < points.size(); ++i) {
      if (!points[i].allFinite()) continue;
      keyed.emplace_back(key(cellOf(points[i])), static_cast<int>(i));
    }
    radixSortByKey(&keyed);  // std::sort's order: keys, then indices (pushed ascending)
    sorted_points_.reserve(keyed.size());
    sorted_indices_.reserve(keyed.size());
    cells_.reserve(keyed.size());
    for (size_t k = 0; k < keyed.size(); ++k) {
      sorted_points_.push_back(points[keyed[k].second]);
      sorted_indices_.push_back(keyed[k].second);
      if (k == 0 || keyed[k].first != keyed[k - 1].first) {
        cells_.emplace(keyed[k].first, std::make_pair(static_cast<int>(k), static_cast<int>(k)));
      }
      cells_[keyed[k].first].second = static_cast<int>(k + 1);
    }
  }

  // The [begin, end) ranges of the stored points in the 27 cells around (and including) `cell`.
  // Queries that share a cell share these ranges, so callers look them up once per cell.
  void neighbourRanges(uint64_t cell_key, std::vector<std::pair<int, int>>* ranges) const {
    ranges->clear();
    const Eigen::Vector3i c = cellFromKey(cell_key);
    for (int dz = -1; dz <= 1; ++dz) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const auto it = cells_.find(key(c + Eigen::Vector3i(dx, dy, dz)));
          if (it != cells_.end()) ranges->push_back(it->second);
        }
      }
    }
  }

  // Squared distances and indices of the points of `ranges` within the radius of q (q itself
  // included).
  void radiusSearch(const Eigen::Vector3f& q, const std::vector<std::pair<int, int>>& ranges,
                    std::vector<std::pair<float, int>>* out) const {
    out->clear();
    for (const std::pair<int, int>& range : ranges) {
      for (int k = range.first; k < range.second; ++k) {
        const float d_sq = (sorted_points_[k] - q).squaredNorm();
        if (d_sq <= radius_sq_) out->emplace_back(d_sq, sorted_indices_[k]);
      }
    }
  }

  uint64_t keyOf(const Eigen::Vector3f& p) const { return key(cellOf(p)); }

 private:
  Eigen::Vector3i cellOf(const Eigen::Vector3f& p) const {
    // Clamped so absurd coordinates cannot overflow the integer conversion.
    const auto index = [this](float v) {
      const double scaled = std::floor(static_cast<double>(v) * inv_cell_);
      return static_cast<int>(std::max(-1e9, std::min(1e9, scaled)));
    };
    return Eigen::Vector3i(index(p.x()), index(p.y()), index(p.z()));
  }
  // Inverse of key() (21-bit two's complement per axis).
  static Eigen::Vector3i cellFromKey(uint64_t k) {
    const auto field = [k](int shift) {
      const int64_t v = static_cast<int64_t>((k >> shift) & ((uint64_t{1} << 21) - 1));
      return static_cast<int>(v >= (int64_t{1} << 20) ? v - (int64_t{1} << 21) : v);
    };
    return Eigen::Vector3i(field(0), field(21), field(42));
  }
  static uint64_t key(const Eigen::Vector3i& c) {
    const uint64_t mask = (uint64_t{1} << 21) - 1;
    return (static_cast<uint64_t>(c.x()) & mask) | ((static_cast<uint64_t>(c.y()) & mask) << 21) |
           ((static_cast<uint64_t>(c.z()) & mask) << 42);
  }

  double inv_cell_;
  float radius_sq_;
  PointCloud sorted_points_;
  std::vector<int> sorted_indices_;
  std::unordered_map<uint64_t, std::pair<int, int>> cells_;  // key -> [begin, end) in sorted arrays
};

// The normal of the plane through a neighbourhood with this covariance: the eigenvector of the
// smallest eigenvalue, unit length; NaN where coincident or collinear points define no plane.
Eigen::Vector3f planeNormal(const Eigen::Matrix3d& covariance) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(covariance);
  const Eigen::Vector3d& eigenvalues = solver.eigenvalues();  // ascending
  if (!(eigenvalues[2] > 0.0) || !(eigenvalues[1] > 1e-6 * eigenvalues[2])) return nanNormal();
  const Eigen::Vector3d normal = solver.eigenvectors().col(0);
  if (!(normal.allFinite() && normal.norm() > 0.5)) return nanNormal();
  return normal.normalized().cast<float>();
}

// The covariance of the points of `neighbours` (squared distance, index), relative to the query
// point q, which keeps double precision far from the origin. The six distinct second moments in
// scalars: the same sums, in the same order, as the outer products (d d^T) added as 3x3 matrices,
// which the compiler spilled to the stack.
Eigen::Matrix3d neighbourCovariance(const PointCloud& points, const Eigen::Vector3f& q,
                                    const std::vector<std::pair<float, int>>& neighbours) {
  double sx = 0.0, sy = 0.0, sz = 0.0;
  double sxx = 0.0, sxy = 0.0, sxz = 0.0, syy = 0.0, syz = 0.0, szz = 0.0;
  for (const auto& n : neighbours) {
    const Eigen::Vector3f& p = points[n.second];
    const double dx = static_cast<double>(p.x() - q.x());
    const double dy = static_cast<double>(p.y() - q.y());
    const double dz = static_cast<double>(p.z() - q.z());
    sx += dx;
    sy += dy;
    sz += dz;
    sxx += dx * dx;
    sxy += dx * dy;
    sxz += dx * dz;
    syy += dy * dy;
    syz += dy * dz;
    szz += dz * dz;
  }
  const Eigen::Vector3d sum(sx, sy, sz);
  Eigen::Matrix3d sum_sq;
  sum_sq << sxx, sxy, sxz, sxy, syy, syz, sxz, syz, szz;
  const double count = static_cast<double>(neighbours.size());
  const Eigen::Vector3d mean = sum / count;
  return sum_sq / count - mean * mean.transpose();
}

// The cells of half the normal radius that estimateCellNormalsAt sums around a query's cell: those
// whose centres lie within the radius of its centre (33 cells).
const std::vector<Eigen::Vector3i>& cellsWithinRadius() {
  static const std::vector<Eigen::Vector3i> kOffsets = [] {
    std::vector<Eigen::Vector3i> offsets;
    for (int dx = -2; dx <= 2; ++dx) {
      for (int dy = -2; dy <= 2; ++dy) {
        for (int dz = -2; dz <= 2; ++dz) {
          if (dx * dx + dy * dy + dz * dz <= 4) offsets.emplace_back(dx, dy, dz);
        }
      }
    }
    return offsets;
  }();
  return kOffsets;
}

// estimateCellNormalsAt's grid: cells of cell_m, keyed relative to a point of the cloud, each
// holding the moments of its points.
class CellMoments {
 public:
  CellMoments(const PointCloud& points, double cell_m) : cell_m_(cell_m) {
    for (const Eigen::Vector3f& p : points) {  // moments relative to a point of the cloud
      if (p.allFinite()) {
        origin_ = p.cast<double>();
        break;
      }
    }
    cells_.reserve(points.size() / 2 + 1);
    Eigen::Vector3i cell;
    for (const Eigen::Vector3f& p : points) {
      if (p.allFinite() && cellOf(p, &cell)) cells_[keyOf(cell)].add(p.cast<double>() - origin_);
    }
  }

  // False for a point beyond the keys' range (a cloud that spans more than 2^20 cells has no
  // meaningful normals at this radius anyway).
  bool cellOf(const Eigen::Vector3f& p, Eigen::Vector3i* cell) const {
    const Eigen::Vector3d c = ((p.cast<double>() - origin_) / cell_m_).array().floor();
    if (!(c.cwiseAbs().maxCoeff() < static_cast<double>(kHalf - 2))) return false;
    *cell = c.cast<int>();
    return true;
  }
  // 21 bits a coordinate, offset so that cells up to 2^20 either side of the origin are positive.
  static std::uint64_t keyOf(const Eigen::Vector3i& c) {
    return (static_cast<std::uint64_t>(c.x() + kHalf) << 42) |
           (static_cast<std::uint64_t>(c.y() + kHalf) << 21) |
           static_cast<std::uint64_t>(c.z() + kHalf);
  }
  // The summed moments of the cells within the radius of `cell`.
  PointMoments around(const Eigen::Vector3i& cell) const {
    PointMoments sum;
    for (const Eigen::Vector3i& offset : cellsWithinRadius()) {
      const auto it = cells_.find(keyOf(cell + offset));
      if (it != cells_.end()) sum.add(it->second);
    }
    return sum;
  }

 private:
  static constexpr std::int64_t kHalf = std::int64_t{1} << 20;
  double cell_m_;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();
  FlatHashMap<std::uint64_t, PointMoments> cells_;
};

}  // namespace

std::vector<Eigen::Vector3f> estimateNormalsAt(const PointCloud& points,
                                               const std::vector<int>& queries, double radius_m,
                                               int max_neighbours, int threads) {
  std::vector<Eigen::Vector3f> normals(queries.size(), nanNormal());
  if (!(std::isfinite(radius_m) && radius_m > 0.0) || max_neighbours < 3) return normals;
  const VoxelNeighbourSearch search(points, radius_m);
  // Queries in cell order, so the 27 neighbour cells are looked up once per occupied cell.
  std::vector<std::pair<uint64_t, int>> order;
  order.reserve(queries.size());
  for (size_t i = 0; i < queries.size(); ++i) {
    if (points[queries[i]].allFinite()) {
      order.emplace_back(search.keyOf(points[queries[i]]), static_cast<int>(i));
    }
  }
  radixSortByKey(&order);  // std::sort's order: keys, then query indices (pushed ascending)
  const auto estimate = [&](size_t first, size_t last) {
    std::vector<std::pair<int, int>> ranges;
    std::vector<std::pair<float, int>> neighbours;
    for (size_t o = first; o < last; ++o) {
      if (o == first || order[o].first != order[o - 1].first)
        search.neighbourRanges(order[o].first, &ranges);
      const int i = order[o].second;
      const Eigen::Vector3f& q = points[queries[i]];
      search.radiusSearch(q, ranges, &neighbours);
      if (neighbours.size() < 3) continue;
      if (static_cast<int>(neighbours.size()) > max_neighbours) {
        std::nth_element(neighbours.begin(), neighbours.begin() + max_neighbours, neighbours.end());
        neighbours.resize(max_neighbours);
      }
      normals[i] = planeNormal(neighbourCovariance(points, q, neighbours));
    }
  };
  // Below a few hundred queries a thread costs more than it saves.
  parallelRanges(order.size(), threads, 512, estimate);
  return normals;
}

std::vector<Eigen::Vector3f> estimateNormals(const PointCloud& points, double radius_m,
                                             int max_neighbours) {
  std::vector<int> queries(points.size());
  for (size_t i = 0; i < points.size(); ++i) queries[i] = static_cast<int>(i);
  return estimateNormalsAt(points, queries, radius_m, max_neighbours);
}

std::vector<Eigen::Vector3f> estimateCellNormalsAt(const PointCloud& points,
                                                   const std::vector<int>& queries, double radius_m,
                                                   int threads) {
  std::vector<Eigen::Vector3f> normals(queries.size(), nanNormal());
  if (!(std::isfinite(radius_m) && radius_m > 0.0)) return normals;
  const CellMoments cells(points, 0.5 * radius_m);
  // Queries in cell order: each cell's normal is computed once.
  std::vector<std::pair<std::uint64_t, int>> order;
  order.reserve(queries.size());
  Eigen::Vector3i cell;
  for (std::size_t i = 0; i < queries.size(); ++i) {
    if (points[queries[i]].allFinite() && cells.cellOf(points[queries[i]], &cell)) {
      order.emplace_back(CellMoments::keyOf(cell), static_cast<int>(i));
    }
  }
  radixSortByKey(&order);
  std::vector<std::size_t> group_begin;  // where each occupied cell's queries start in `order`
  for (std::size_t o = 0; o < order.size(); ++o) {
    if (o == 0 || order[o].first != order[o - 1].first) group_begin.push_back(o);
  }
  group_begin.push_back(order.size());
  const auto estimate = [&](std::size_t first_group, std::size_t last_group) {
    Eigen::Vector3i query_cell;
    for (std::size_t g = first_group; g < last_group; ++g) {
      cells.cellOf(points[queries[order[group_begin[g]].second]], &query_cell);
      const PointMoments around = cells.around(query_cell);
      const Eigen::Vector3f normal =
          around.n >= 3.0 ? planeNormal(around.covariance()) : nanNormal();
      for (std::size_t o = group_begin[g]; o < group_begin[g + 1]; ++o) {
        normals[order[o].second] = normal;
      }
    }
  };
  // Below a few hundred cells a thread costs more than it saves.
  parallelRanges(group_begin.size() - 1, threads, 512, estimate);
  return normals;
}

}  // namespace mvod
