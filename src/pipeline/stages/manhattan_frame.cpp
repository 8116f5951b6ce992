#include "multiview_object_detection/pipeline/stages/manhattan_frame.h"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <sstream>
#include <unordered_map>

#include "multiview_object_detection/pipeline/utils/flat_hash_map.h"
#include "multiview_object_detection/pipeline/utils/point_moments.h"
#include "multiview_object_detection/pipeline/utils/radix_sort.h"

namespace mvod {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kHalfPi = 0.5 * kPi;
constexpr double kQuarterPi = 0.25 * kPi;

// SO(3) search (Eq. 3 over all rotations): how many normals propose a first axis, how many of the
// best proposals are polished and scored on all normals, and how many normals score the proposals.
constexpr int kNumAxisCandidates = 64;
constexpr int kNumRefinedCandidates = 4;
constexpr int kMaxScoringNormals = 600;
constexpr int kPolishIterations = 10;

// A Manhattan yaw is trusted only if its horizontal inliers clearly stand out from the yaw-averaged
// count (a cylinder or a flat slab gives a nearly flat inlier-vs-yaw curve); otherwise BoxEstimator
// falls back to the minimum-area footprint.
constexpr double kMinPeakToMeanRatio = 1.5;
constexpr int kMinHorizontalInliers = 5;
// The footprint's minimum-area yaw is trusted only for a footprint this elongated (long / short).
constexpr double kMinFootprintAspect = 1.5;

// ---------------------------------------------------------------------------------------------------
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

Eigen::Vector3f nanNormal() {
  return Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
}

// PCA normals of points[queries[i]] (the eigenvector of the smallest eigenvalue of the neighbour
// covariance). Shared by estimateNormals and BoxEstimator, which only needs normals at a subsample.
// threads: the queries split over this many threads (each query is independent: same result).
std::vector<Eigen::Vector3f> normalsAt(const PointCloud& points, const std::vector<int>& queries,
                                       double radius_m, int max_neighbours, int threads = 1) {
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
      // Moments relative to the query point keep double precision far from the origin.
      // The six distinct second moments in scalars: the same sums, in the same order, as the outer
      // products (d d^T) added as 3x3 matrices, which the compiler spilled to the stack.
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
      const Eigen::Matrix3d covariance = sum_sq / count - mean * mean.transpose();
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
      solver.computeDirect(covariance);
      const Eigen::Vector3d& eigenvalues = solver.eigenvalues();  // ascending
      // Coincident or collinear neighbours do not define a plane.
      if (!(eigenvalues[2] > 0.0) || !(eigenvalues[1] > 1e-6 * eigenvalues[2])) continue;
      const Eigen::Vector3d normal = solver.eigenvectors().col(0);
      if (normal.allFinite() && normal.norm() > 0.5) normals[i] = normal.normalized().cast<float>();
    }
  };
  // Below a few hundred queries a thread costs more than it saves.
  parallelRanges(order.size(), threads, 512, estimate);
  return normals;
}

// Normals at `queries` from cell moments: cells of half the radius, and for a query the summed
// moments of the cells whose centres lie within the radius of its cell's centre (33 cells), PCA
// as in normalsAt. Queries in one cell share its normal, so the cost is that of the occupied cells,
// whatever the radius.
// threads: the occupied cells split over this many threads (each cell's normal is independent:
// the same result).
std::vector<Eigen::Vector3f> normalsOnCells(const PointCloud& points,
                                            const std::vector<int>& queries, double radius_m,
                                            int threads = 1) {
  std::vector<Eigen::Vector3f> normals(queries.size(), nanNormal());
  if (!(std::isfinite(radius_m) && radius_m > 0.0)) return normals;
  const double cell_m = 0.5 * radius_m;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // moments relative to a point of the cloud
  for (const Eigen::Vector3f& p : points) {
    if (p.allFinite()) {
      origin = p.cast<double>();
      break;
    }
  }
  // Cell keys: 21 bits a coordinate, offset so that cells up to 2^20 either side of the origin
  // are positive (a cloud that spans more has no meaningful normals at this radius anyway).
  constexpr std::int64_t kHalf = std::int64_t{1} << 20;
  const auto cellOf = [&](const Eigen::Vector3f& p, Eigen::Vector3i* cell) {
    const Eigen::Vector3d c = ((p.cast<double>() - origin) / cell_m).array().floor();
    if (!(c.cwiseAbs().maxCoeff() < static_cast<double>(kHalf - 2))) return false;
    *cell = c.cast<int>();
    return true;
  };
  const auto keyOf = [kHalf](const Eigen::Vector3i& c) {
    return (static_cast<std::uint64_t>(c.x() + kHalf) << 42) |
           (static_cast<std::uint64_t>(c.y() + kHalf) << 21) |
           static_cast<std::uint64_t>(c.z() + kHalf);
  };
  FlatHashMap<std::uint64_t, PointMoments> cells;
  cells.reserve(points.size() / 2 + 1);
  Eigen::Vector3i cell;
  for (const Eigen::Vector3f& p : points) {
    if (p.allFinite() && cellOf(p, &cell)) cells[keyOf(cell)].add(p.cast<double>() - origin);
  }
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
  // Queries in cell order: each cell's normal is computed once.
  std::vector<std::pair<std::uint64_t, int>> order;
  order.reserve(queries.size());
  for (std::size_t i = 0; i < queries.size(); ++i) {
    if (points[queries[i]].allFinite() && cellOf(points[queries[i]], &cell)) {
      order.emplace_back(keyOf(cell), static_cast<int>(i));
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
      cellOf(points[queries[order[group_begin[g]].second]], &query_cell);
      PointMoments around;
      for (const Eigen::Vector3i& offset : kOffsets) {
        const auto it = cells.find(keyOf(query_cell + offset));
        if (it != cells.end()) around.add(it->second);
      }
      Eigen::Vector3f normal = nanNormal();
      if (around.n >= 3.0) {
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
        solver.computeDirect(around.covariance());
        const Eigen::Vector3d& eigenvalues = solver.eigenvalues();  // ascending
        // Coincident or collinear points do not define a plane.
        if (eigenvalues[2] > 0.0 && eigenvalues[1] > 1e-6 * eigenvalues[2]) {
          const Eigen::Vector3d n = solver.eigenvectors().col(0);
          if (n.allFinite() && n.norm() > 0.5) normal = n.normalized().cast<float>();
        }
      }
      for (std::size_t o = group_begin[g]; o < group_begin[g + 1]; ++o) {
        normals[order[o].second] = normal;
      }
    }
  };
  // Below a few hundred cells a thread costs more than it saves.
  parallelRanges(group_begin.size() - 1, threads, 512, estimate);
  return normals;
}

// Deterministic stride so that at most max_count of n items are kept.
int strideFor(size_t n, int max_count) {
  if (max_count <= 0 || n <= static_cast<size_t>(max_count)) return 1;
  return static_cast<int>((n + max_count - 1) / max_count);
}

// Finite, non-zero normals (normalised, double), subsampled by stride to at most max_normals.
std::vector<Eigen::Vector3d> prepareNormals(const std::vector<Eigen::Vector3f>& normals,
                                            int max_normals) {
  const int stride = strideFor(normals.size(), max_normals);
  std::vector<Eigen::Vector3d> result;
  result.reserve(normals.size() / stride + 1);
  for (size_t i = 0; i < normals.size(); i += stride) {
    const Eigen::Vector3d n = normals[i].cast<double>();
    const double norm = n.norm();
    if (!std::isfinite(norm) || norm < 1e-6) continue;
    result.push_back(n / norm);
  }
  return result;
}

template <typename T>
std::vector<T> strided(const std::vector<T>& items, int max_count) {
  const int stride = strideFor(items.size(), max_count);
  if (stride == 1) return items;
  std::vector<T> result;
  for (size_t i = 0; i < items.size(); i += stride) result.push_back(items[i]);
  return result;
}

// Folds an angle into [0, pi/2).
double foldQuarter(double angle) {
  double a = fmodSmall(angle, kHalfPi);
  if (a < 0.0) a += kHalfPi;
  if (a >= kHalfPi) a -= kHalfPi;
  return a;
}

// Folds a yaw into [-pi/4, pi/4): the four horizontal axes of a gravity-aligned frame are
// equivalent.
double foldYaw(double yaw_rad) {
  const double a = foldQuarter(yaw_rad);
  return a >= kQuarterPi ? a - kHalfPi : a;
}

// Arc of yaw (folded into one quarter turn) over which a normal is an inlier of a horizontal axis.
struct YawArc {
  enum Kind { kNever, kAlways, kArc } kind = kNever;
  double start = 0.0;       // in [0, pi/2)
  double half_width = 0.0;  // < pi/4 for an arc
};

// A unit normal's horizontal geometry in a gravity frame, computed once and shared by Eq. 3's yaw
// sweep, the structure test and the polish (each used to redo the trigonometry per normal).
struct HorizontalNormal {
  bool vertical = false;  // within δ of ±up: an inlier at every yaw, and not horizontal
  double h = 0.0;         // length of the horizontal part (not computed for vertical normals)
  double theta = 0.0;     // its angle from x_h (computed only where h >= cos δ)
  YawArc arc;
};

HorizontalNormal horizontalNormalOf(const Eigen::Vector3d& n, const Eigen::Vector3d& up,
                                    const Eigen::Vector3d& x_h, const Eigen::Vector3d& y_h,
                                    double cos_delta) {
  HorizontalNormal result;
  YawArc& arc = result.arc;
  if (std::abs(n.dot(up)) >= cos_delta) {
    result.vertical = true;
    arc.kind = YawArc::kAlways;
    return result;
  }
  const double hx = n.dot(x_h);
  const double hy = n.dot(y_h);
  result.h = std::hypot(hx, hy);
  // angle(n, axis at yaw psi) <= δ  <=>  h cos(theta - psi) >= cos δ.
  if (result.h < cos_delta) return result;
  result.theta = std::atan2(hy, hx);
  arc.half_width = std::acos(std::min(1.0, cos_delta / result.h));
  if (2.0 * arc.half_width >= kHalfPi) {  // only for δ >= 45°
    arc.kind = YawArc::kAlways;
    return result;
  }
  arc.kind = YawArc::kArc;
  arc.start = foldQuarter(result.theta - arc.half_width);
  return result;
}

std::vector<HorizontalNormal> horizontalNormals(const std::vector<Eigen::Vector3d>& normals,
                                                const Eigen::Vector3d& up,
                                                const Eigen::Vector3d& x_h,
                                                const Eigen::Vector3d& y_h, double cos_delta) {
  std::vector<HorizontalNormal> result;
  result.reserve(normals.size());
  for (const Eigen::Vector3d& n : normals) {
    result.push_back(horizontalNormalOf(n, up, x_h, y_h, cos_delta));
  }
  return result;
}

struct YawSweepResult {
  double psi = 0.0;  // in [0, pi/2)
  int inliers = 0;
};

// Exact maximiser of the gravity-constrained Eq. 3 over yaw: each normal is an inlier on a closed
// arc of yaw (mod 90°); a sweep over the sorted arc end points visits every piece of the
// piecewise-constant count. Among the maximal pieces the widest wins and its middle is returned.
YawSweepResult sweepArcs(const std::vector<HorizontalNormal>& normals) {
  std::vector<double> starts, ends;
  starts.reserve(normals.size());
  ends.reserve(normals.size());
  int base = 0;  // count at psi = 0: normals inlier everywhere plus arcs that wrap past pi/2
  for (const HorizontalNormal& n : normals) {
    const YawArc& arc = n.arc;
    if (arc.kind == YawArc::kAlways) {
      ++base;
    } else if (arc.kind == YawArc::kArc) {
      const double end = arc.start + 2.0 * arc.half_width;
      starts.push_back(arc.start);
      if (end < kHalfPi) {
        ends.push_back(end);
      } else {  // wraps: [start, pi/2) and [0, end - pi/2]
        ++base;
        ends.push_back(end - kHalfPi);
      }
    }
  }
  YawSweepResult result;
  result.inliers = base;
  if (starts.empty()) return result;  // constant count: any yaw, take 0
  // The end points in order; closed arcs: at equal angles, starts come before ends. Two sorts of
  // plain angles and a merge give the order of one sort of (angle, kind) pairs.
  sortNonNegative(&starts);
  sortNonNegative(&ends);
  std::vector<std::pair<double, int>> events;  // (angle, +1 start / -1 end)
  events.reserve(starts.size() + ends.size());
  std::size_t i_start = 0, i_end = 0;
  while (i_start < starts.size() || i_end < ends.size()) {
    if (i_end == ends.size() || (i_start < starts.size() && starts[i_start] <= ends[i_end])) {
      events.emplace_back(starts[i_start++], +1);
    } else {
      events.emplace_back(ends[i_end++], -1);
    }
  }

  // The count on the first piece [0, events[0]] and on the last piece [events.back(), pi/2) is
  // `base` (every arc that starts also ends); these two pieces are one across the wrap.
  int best = base;
  double best_width = events.front().first + (kHalfPi - events.back().first);
  double best_psi = foldQuarter(events.back().first + 0.5 * best_width);
  int count = base;
  for (size_t i = 0; i + 1 < events.size(); ++i) {
    count += events[i].second;
    // After event i the count holds on [events[i], events[i+1]] (exactly for a piece of positive
    // width; a zero-width piece at a shared end point is exact once all its starts and none of its
    // ends are in).
    const double width = events[i + 1].first - events[i].first;
    if (count > best || (count == best && width > best_width)) {
      best = count;
      best_width = width;
      best_psi = events[i].first + 0.5 * width;
    }
  }
  result.psi = foldQuarter(best_psi);
  result.inliers = best;
  return result;
}

YawSweepResult sweepYaw(const std::vector<Eigen::Vector3d>& normals, const Eigen::Vector3d& up,
                        const Eigen::Vector3d& x_h, const Eigen::Vector3d& y_h, double cos_delta) {
  return sweepArcs(horizontalNormals(normals, up, x_h, y_h, cos_delta));
}

bool isInlier(const Eigen::Vector3d& n, const Eigen::Matrix3d& R, double cos_delta) {
  for (int j = 0; j < 3; ++j) {
    if (std::abs(n.dot(R.col(j))) >= cos_delta) return true;
  }
  return false;
}

int countInliersUnit(const std::vector<Eigen::Vector3d>& normals, const Eigen::Matrix3d& R,
                     double cos_delta) {
  int count = 0;
  for (const Eigen::Vector3d& n : normals) count += isInlier(n, R, cos_delta) ? 1 : 0;
  return count;
}

// Least-squares polish of a consensus frame (Eq. 3's objective is flat over a range of rotations
// about the optimum, so its argmax alone is imprecise): each axis becomes the mean of its
// sign-aligned inlier normals, and the three means are projected back onto SO(3) (polar
// decomposition); repeated a few times.
Eigen::Matrix3d polishFrame(const std::vector<Eigen::Vector3d>& normals, const Eigen::Matrix3d& R,
                            double cos_delta) {
  Eigen::Matrix3d current = R;
  for (int iteration = 0; iteration < kPolishIterations; ++iteration) {
    Eigen::Matrix3d sums = Eigen::Matrix3d::Zero();
    for (const Eigen::Vector3d& n : normals) {
      for (int j = 0; j < 3; ++j) {
        const double d = n.dot(current.col(j));
        if (std::abs(d) >= cos_delta) {
          sums.col(j) += d > 0.0 ? n : Eigen::Vector3d(-n);
          break;
        }
      }
    }
    for (int j = 0; j < 3; ++j) {
      if (sums.col(j).norm() < 1e-9) sums.col(j) = current.col(j);  // an axis without inliers stays
    }
    const Eigen::Matrix3d polished = nearestRotation(sums);
    if (!polished.allFinite()) break;
    const double change = (polished - current).norm();
    current = polished;
    if (change < 1e-9) break;
  }
  return current;
}

// The same polish for a gravity-aligned frame: the yaw moves to the mean (folded) horizontal angle
// of the normals that are inliers of a horizontal axis, repeated a few times (a flat-kernel mean
// shift).
double polishYaw(const std::vector<HorizontalNormal>& normals, double yaw_rad, double cos_delta) {
  double psi = yaw_rad;
  for (int iteration = 0; iteration < kPolishIterations; ++iteration) {
    double sum = 0.0;
    int count = 0;
    for (const HorizontalNormal& n : normals) {
      if (n.vertical || n.h < cos_delta) continue;
      const double offset = foldYaw(n.theta - psi);
      if (n.h * std::cos(offset) < cos_delta) continue;
      sum += offset;
      ++count;
    }
    if (count == 0) break;
    const double step = sum / count;
    psi += step;
    if (std::abs(step) < 1e-9) break;
  }
  return foldYaw(psi);
}

// True if, at this yaw, the horizontal inliers stand out from their average over all yaws (see
// kMinPeakToMeanRatio): the Manhattan yaw is then meaningful.
bool hasHorizontalStructure(const std::vector<HorizontalNormal>& normals, double yaw_rad) {
  const double psi = foldQuarter(yaw_rad);
  double total_arc = 0.0;
  int inliers = 0;
  for (const HorizontalNormal& n : normals) {
    const YawArc& arc = n.arc;
    if (arc.kind != YawArc::kArc) continue;
    total_arc += 2.0 * arc.half_width;
    const double offset = foldQuarter(psi - arc.start);
    if (offset <= 2.0 * arc.half_width) ++inliers;
  }
  const double mean_inliers = total_arc / kHalfPi;
  return inliers >= kMinHorizontalInliers && inliers >= kMinPeakToMeanRatio * mean_inliers;
}

// The points on the horizontal plane (x_h, y_h) and their bounds: computed once per box for the
// outline's normals, the footprint's strip ends and the minimum-area fallback.
struct Footprint {
  std::vector<Eigen::Vector2d> points;
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
};

Footprint projectFootprint(const PointCloud& points_W, const GravityFrame& gravity) {
  Footprint footprint;
  footprint.points.resize(points_W.size());
  for (size_t i = 0; i < points_W.size(); ++i) {
    const Eigen::Vector3d q = points_W[i].cast<double>();
    footprint.points[i] = Eigen::Vector2d(q.dot(gravity.x_h), q.dot(gravity.y_h));
    footprint.lo = footprint.lo.cwiseMin(footprint.points[i]);
    footprint.hi = footprint.hi.cwiseMax(footprint.points[i]);
  }
  return footprint;
}

// Fallback when the normals carry no Manhattan structure: the yaw of the minimum-area rectangle
// around the footprint (the optimal rectangle has a side on a convex hull edge, so every edge
// direction is tried).
double minimumAreaYaw(const Footprint& footprint) {
  return foldYaw(minimumAreaRectangle(footprint.points).yaw_rad);
}

// The footprint outline's horizontal normals: the points' occupancy on a horizontal grid, closed
// and smoothed, and the gradient direction wherever it is steep (a band along the boundary). The
// grid is coarsened for very large footprints (at most 1000 cells a side).
std::vector<Eigen::Vector3f> outlineNormals(const Footprint& projected, const GravityFrame& gravity,
                                            double cell_m) {
  std::vector<Eigen::Vector3f> normals;
  if (projected.points.size() < 3 || !(cell_m > 0.0)) return normals;
  const std::vector<Eigen::Vector2d>& footprint = projected.points;
  const Eigen::Vector2d& lo = projected.lo;
  const Eigen::Vector2d& hi = projected.hi;
  const double span_m = (hi - lo).maxCoeff();
  if (!std::isfinite(span_m)) return normals;
  cell_m = std::max(cell_m, span_m / 1000.0);
  const int pad = 3;
  const int cols = static_cast<int>((hi.x() - lo.x()) / cell_m) + 1 + 2 * pad;
  const int rows = static_cast<int>((hi.y() - lo.y()) / cell_m) + 1 + 2 * pad;
  cv::Mat occupied(rows, cols, CV_8UC1, cv::Scalar(0));
  for (const Eigen::Vector2d& f : footprint) {
    const int c = static_cast<int>((f.x() - lo.x()) / cell_m) + pad;
    const int r = static_cast<int>((f.y() - lo.y()) / cell_m) + pad;
    occupied.ptr<uint8_t>(r)[c] = 255;
  }
  cv::morphologyEx(occupied, occupied, cv::MORPH_CLOSE,
                   cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
  cv::Mat smooth, gx, gy;
  occupied.convertTo(smooth, CV_32F, 1.0 / 255.0);
  cv::GaussianBlur(smooth, smooth, cv::Size(5, 5), 1.0);
  cv::Sobel(smooth, gx, CV_32F, 1, 0, 3);
  cv::Sobel(smooth, gy, CV_32F, 0, 1, 3);
  const Eigen::Vector3f x_h = gravity.x_h.cast<float>();
  const Eigen::Vector3f y_h = gravity.y_h.cast<float>();
  // A straight edge's gradient peaks near 4 x 0.4 (Sobel's weights over the blurred step).
  const float min_magnitude = 0.8f;
  for (int r = 0; r < rows; ++r) {
    const float* row_x = gx.ptr<float>(r);
    const float* row_y = gy.ptr<float>(r);
    for (int c = 0; c < cols; ++c) {
      const float magnitude = std::hypot(row_x[c], row_y[c]);
      if (magnitude < min_magnitude) continue;
      normals.push_back(((row_x[c] * x_h + row_y[c] * y_h) / magnitude).normalized());
    }
  }
  return normals;
}

// The footprint's outline, approximately and in O(n): of each 1 cm strip along either horizontal
// axis, only the points at both ends (every hull vertex lies within a strip's width of these).
// Rectangles around these are those around the whole footprint to about a centimetre.
std::vector<Eigen::Vector2d> footprintStripEnds(const Footprint& projected) {
  const std::vector<Eigen::Vector2d>& footprint = projected.points;
  const Eigen::Vector2d& lo = projected.lo;
  const Eigen::Vector2d& hi = projected.hi;
  std::vector<Eigen::Vector2d> ends;
  if (footprint.empty()) return ends;
  const double strip_m = std::max(0.01, (hi - lo).maxCoeff() / 2000.0);
  for (int axis = 0; axis < 2; ++axis) {
    const int other = 1 - axis;
    const size_t strips = static_cast<size_t>((hi[axis] - lo[axis]) / strip_m) + 1;
    std::vector<int> low(strips, -1), high(strips, -1);
    for (size_t i = 0; i < footprint.size(); ++i) {
      const size_t k = static_cast<size_t>((footprint[i][axis] - lo[axis]) / strip_m);
      if (k >= strips) continue;
      if (low[k] < 0 || footprint[i][other] < footprint[low[k]][other])
        low[k] = static_cast<int>(i);
      if (high[k] < 0 || footprint[i][other] > footprint[high[k]][other]) {
        high[k] = static_cast<int>(i);
      }
    }
    for (size_t k = 0; k < strips; ++k) {
      if (low[k] >= 0) ends.push_back(footprint[low[k]]);
      if (high[k] >= 0 && high[k] != low[k]) ends.push_back(footprint[high[k]]);
    }
  }
  return ends;
}

// Area of the rectangle at this yaw (footprint coordinates) around the points.
double rectangleArea(const std::vector<Eigen::Vector2d>& points, double yaw_rad) {
  const Eigen::Vector2d u(std::cos(yaw_rad), std::sin(yaw_rad));
  const Eigen::Vector2d v(-u.y(), u.x());
  double min_u = std::numeric_limits<double>::infinity(), max_u = -min_u;
  double min_v = min_u, max_v = -min_u;
  for (const Eigen::Vector2d& q : points) {
    min_u = std::min(min_u, q.dot(u));
    max_u = std::max(max_u, q.dot(u));
    min_v = std::min(min_v, q.dot(v));
    max_v = std::max(max_v, q.dot(v));
  }
  return (max_u - min_u) * (max_v - min_v);
}

}  // namespace

std::vector<Eigen::Vector3f> estimateNormals(const PointCloud& points, double radius_m,
                                             int max_neighbours) {
  std::vector<int> queries(points.size());
  for (size_t i = 0; i < points.size(); ++i) queries[i] = static_cast<int>(i);
  return normalsAt(points, queries, radius_m, max_neighbours);
}

// ---------------------------------------------------------------------------------------------------

Status ManhattanFrameEstimator::Config::isValid() const {
  // Above 45° the six axes' cones overlap and Eq. 3 stops distinguishing orientations.
  if (!(std::isfinite(inlier_angle_deg) && inlier_angle_deg > 0.0 && inlier_angle_deg <= 45.0)) {
    return Status::Error("manhattan inlier_angle_deg must be in (0, 45] (got " +
                         std::to_string(inlier_angle_deg) + ")");
  }
  if (!(std::isfinite(normal_radius_m) && normal_radius_m > 0.0)) {
    return Status::Error("manhattan normal_radius_m must be a finite value > 0 (got " +
                         std::to_string(normal_radius_m) + ")");
  }
  if (max_normals < 3) {
    return Status::Error("manhattan max_normals must be >= 3 (got " + std::to_string(max_normals) +
                         ")");
  }
  return Status::Ok();
}

std::string ManhattanFrameEstimator::Config::print() const {
  std::ostringstream out;
  out << "inlier_angle_deg: " << inlier_angle_deg << "\n"
      << "normal_radius_m: " << normal_radius_m << "\n"
      << "max_normals: " << max_normals << "\n"
      << "gravity_constrained: " << (gravity_constrained ? "true" : "false") << "\n";
  return out.str();
}

int ManhattanFrameEstimator::countInliers(const std::vector<Eigen::Vector3f>& normals,
                                          const Eigen::Matrix3d& R) const {
  const double cos_delta = std::cos(config_.inlier_angle_deg * kPi / 180.0);
  int count = 0;
  for (const Eigen::Vector3f& normal : normals) {
    const Eigen::Vector3d n = normal.cast<double>();
    const double norm = n.norm();
    if (!std::isfinite(norm) || norm < 1e-6) continue;
    count += isInlier(n / norm, R, cos_delta) ? 1 : 0;
  }
  return count;
}

ManhattanFrameEstimator::Result ManhattanFrameEstimator::estimateYaw(
    const std::vector<Eigen::Vector3f>& normals_W, const GravityFrame& gravity) const {
  const double cos_delta = std::cos(config_.inlier_angle_deg * kPi / 180.0);
  const std::vector<Eigen::Vector3d> normals = prepareNormals(normals_W, config_.max_normals);
  const YawSweepResult sweep = sweepYaw(normals, gravity.up, gravity.x_h, gravity.y_h, cos_delta);
  Result result;
  result.yaw_rad = foldYaw(sweep.psi);
  result.R_W_MF = gravity.rotationFromYaw(result.yaw_rad);
  result.inliers = sweep.inliers;
  result.num_normals = static_cast<int>(normals.size());
  return result;
}

// Eq. 3 over SO(3). Not the branch-and-bound of [28]: a first axis is proposed by (a stride
// subsample of) the normals themselves, the rest of the frame is the exact yaw optimum about it,
// the best proposals are polished by inlier averaging (polishFrame), and the largest consensus on
// all (subsampled) normals wins. yaw_rad is the yaw of column 0 about column 2 measured in the
// GravityFrame built on column 2, i.e. always folded but not relative to any gravity: gravity users
// convert R_W_MF themselves.
ManhattanFrameEstimator::Result ManhattanFrameEstimator::estimateSO3(
    const std::vector<Eigen::Vector3f>& normals_W) const {
  const double cos_delta = std::cos(config_.inlier_angle_deg * kPi / 180.0);
  const std::vector<Eigen::Vector3d> normals = prepareNormals(normals_W, config_.max_normals);
  Result result;
  result.num_normals = static_cast<int>(normals.size());
  if (normals.empty()) return result;

  const std::vector<Eigen::Vector3d> scoring = strided(normals, kMaxScoringNormals);
  const std::vector<Eigen::Vector3d> axes = strided(normals, kNumAxisCandidates);
  struct Candidate {
    int score;
    int index;
  };
  std::vector<Candidate> candidates;
  candidates.reserve(axes.size());
  for (size_t i = 0; i < axes.size(); ++i) {
    const GravityFrame frame(-axes[i]);
    const YawSweepResult sweep = sweepYaw(scoring, frame.up, frame.x_h, frame.y_h, cos_delta);
    candidates.push_back({sweep.inliers, static_cast<int>(i)});
  }
  const size_t num_refined = std::min<size_t>(kNumRefinedCandidates, candidates.size());
  std::partial_sort(candidates.begin(), candidates.begin() + num_refined, candidates.end(),
                    [](const Candidate& a, const Candidate& b) {
                      return a.score > b.score || (a.score == b.score && a.index < b.index);
                    });

  int best_count = -1;
  for (size_t c = 0; c < num_refined; ++c) {
    const GravityFrame frame(-axes[candidates[c].index]);
    const YawSweepResult sweep = sweepYaw(normals, frame.up, frame.x_h, frame.y_h, cos_delta);
    const Eigen::Matrix3d R = polishFrame(normals, frame.rotationFromYaw(sweep.psi), cos_delta);
    const int count = countInliersUnit(normals, R, cos_delta);
    if (count > best_count) {
      best_count = count;
      result.R_W_MF = R;
      result.yaw_rad = foldYaw(GravityFrame(-R.col(2)).yawOf(R.col(0)));
    }
  }
  result.inliers = best_count;
  return result;
}

// ---------------------------------------------------------------------------------------------------

Status BoxEstimator::Config::isValid() const {
  const Status manhattan_status = manhattan.isValid();
  if (!manhattan_status.ok()) return manhattan_status;
  if (min_points < 1) {
    return Status::Error("box min_points must be >= 1 (got " + std::to_string(min_points) + ")");
  }
  if (num_threads < 1 || num_threads > 256) {
    return Status::Error("box num_threads must be in [1, 256] (got " + std::to_string(num_threads) +
                         ")");
  }
  if (!(std::isfinite(depth_step_per_m2) && depth_step_per_m2 >= 0.0 && depth_step_per_m2 < 0.1)) {
    return Status::Error("box depth_step_per_m2 must be in [0, 0.1) (got " +
                         std::to_string(depth_step_per_m2) + ")");
  }
  if (!(std::isfinite(outline_cell_m) && outline_cell_m >= 0.0)) {
    return Status::Error("box outline_cell_m must be >= 0 (got " + std::to_string(outline_cell_m) +
                         ")");
  }
  if (normal_estimation != "cells" && normal_estimation != "radius") {
    return Status::Error("box normal_estimation must be cells or radius (got '" +
                         normal_estimation + "')");
  }
  if (!(footprint_yaw_area_ratio >= 0.0 && footprint_yaw_area_ratio <= 1.0)) {
    return Status::Error("box footprint_yaw_area_ratio must be in [0, 1] (got " +
                         std::to_string(footprint_yaw_area_ratio) + ")");
  }
  if (!(extent_trim_fraction >= 0.0 && extent_trim_fraction < 0.2)) {
    return Status::Error("box extent_trim_fraction must be in [0, 0.2) (got " +
                         std::to_string(extent_trim_fraction) + ")");
  }
  return Status::Ok();
}

std::string BoxEstimator::Config::print() const {
  std::ostringstream out;
  std::istringstream manhattan_lines(manhattan.print());
  for (std::string line; std::getline(manhattan_lines, line);) {
    out << "manhattan." << line << "\n";
  }
  out << "min_points: " << min_points << "\n"
      << "extent_trim_fraction: " << extent_trim_fraction << "\n"
      << "depth_step_per_m2: " << depth_step_per_m2 << "\n"
      << "footprint_yaw_area_ratio: " << footprint_yaw_area_ratio << "\n"
      << "outline_cell_m: " << outline_cell_m << "\n"
      << "normal_estimation: " << normal_estimation << "\n";
  return out.str();
}

Status BoxEstimator::estimate(const PointCloud& points_W, const GravityFrame& gravity,
                              OrientedBox* box, ManhattanFrameEstimator::Result* frame,
                              std::vector<Eigen::Vector3f>* normals_W, double view_depth_m) const {
  if (normals_W != nullptr) normals_W->assign(points_W.size(), nanNormal());
  // Non-finite points are dropped, not fatal; `source` maps the kept points back.
  PointCloud points;
  std::vector<int> source;
  const Status checked = checkedInput("estimate", points_W, gravity, box, &points, &source);
  if (!checked) return checked;

  // Normals only at the (stride) subsample that Eq. 3 will use, with the full cloud as neighbours.
  const ManhattanFrameEstimator::Config& mf_config = config_.manhattan;
  const int stride = strideFor(points.size(), mf_config.max_normals);
  std::vector<int> queries;
  queries.reserve(points.size() / stride + 1);
  for (size_t i = 0; i < points.size(); i += stride) queries.push_back(static_cast<int>(i));
  // The neighbour cap grows with the radius's area, so that a grown radius is used (on a 1 cm grid
  // the 30 nearest points lie within 3 cm).
  const double radius_m = normalRadius(view_depth_m);
  const double area_ratio = std::pow(radius_m / mf_config.normal_radius_m, 2.0);
  const int max_neighbours = static_cast<int>(std::min(400.0, std::ceil(30.0 * area_ratio)));
  const std::vector<Eigen::Vector3f> normals =
      config_.normal_estimation == "cells"
          ? normalsOnCells(points, queries, radius_m, config_.num_threads)
          : normalsAt(points, queries, radius_m, max_neighbours, config_.num_threads);
  if (normals_W != nullptr) {
    for (size_t q = 0; q < queries.size(); ++q) (*normals_W)[source[queries[q]]] = normals[q];
  }
  return boxFromNormals(points, normals, gravity, box, frame);
}

Status BoxEstimator::checkedInput(const std::string& caller, const PointCloud& points_W,
                                  const GravityFrame& gravity, const OrientedBox* box,
                                  PointCloud* points, std::vector<int>* source) const {
  const std::string where = "BoxEstimator::" + caller + ": ";
  if (box == nullptr) return Status::Error(where + "box is null");
  const Status config_status = config_.isValid();
  if (!config_status.ok()) return config_status;
  if (!gravity.up.allFinite() || !gravity.x_h.allFinite()) {
    return Status::Error(where + "gravity frame is not finite");
  }
  points->clear();
  points->reserve(points_W.size());
  if (source != nullptr) {
    source->clear();
    source->reserve(points_W.size());
  }
  for (size_t i = 0; i < points_W.size(); ++i) {
    if (!points_W[i].allFinite()) continue;
    points->push_back(points_W[i]);
    if (source != nullptr) source->push_back(static_cast<int>(i));
  }
  if (points->empty() || static_cast<int>(points->size()) < config_.min_points) {
    return Status::Error(where + std::to_string(points->size()) + " finite points, need at least " +
                         std::to_string(config_.min_points));
  }
  return Status::Ok();
}

double BoxEstimator::normalRadius(double view_depth_m) const {
  const double radius_m = config_.manhattan.normal_radius_m;
  if (!(std::isfinite(view_depth_m) && view_depth_m > 0.0)) return radius_m;
  // Capped: a far, noisy view must not make the neighbour search cover the whole object.
  const double layer_m = config_.depth_step_per_m2 * view_depth_m * view_depth_m;
  return std::min(std::max(radius_m, 2.0 * layer_m), std::max(radius_m, 0.15));
}

Status BoxEstimator::estimateFromNormals(const PointCloud& points_W,
                                         const std::vector<Eigen::Vector3f>& normals_W,
                                         const GravityFrame& gravity, OrientedBox* box,
                                         ManhattanFrameEstimator::Result* frame) const {
  PointCloud points;
  const Status checked =
      checkedInput("estimateFromNormals", points_W, gravity, box, &points, nullptr);
  if (!checked) return checked;
  return boxFromNormals(points, normals_W, gravity, box, frame);
}

Status BoxEstimator::boxFromNormals(const PointCloud& points,
                                    const std::vector<Eigen::Vector3f>& normals,
                                    const GravityFrame& gravity, OrientedBox* box,
                                    ManhattanFrameEstimator::Result* frame) const {
  const ManhattanFrameEstimator::Config& mf_config = config_.manhattan;
  const double cos_delta = std::cos(mf_config.inlier_angle_deg * kPi / 180.0);
  // The surface normals, and in the gravity-constrained search those of the footprint's outline.
  std::optional<Footprint> projected;  // the footprint, projected when first needed
  const auto footprint = [&]() -> const Footprint& {
    if (!projected) projected = projectFootprint(points, gravity);
    return *projected;
  };
  std::vector<Eigen::Vector3f> with_outline;
  if (mf_config.gravity_constrained && config_.outline_cell_m > 0.0) {
    with_outline = normals;
    const std::vector<Eigen::Vector3f> outline =
        outlineNormals(footprint(), gravity, config_.outline_cell_m);
    with_outline.insert(with_outline.end(), outline.begin(), outline.end());
  }
  const std::vector<Eigen::Vector3f>& eq3_normals = with_outline.empty() ? normals : with_outline;
  const std::vector<Eigen::Vector3d> unit_normals =
      prepareNormals(eq3_normals, mf_config.max_normals);
  // Their horizontal geometry in the gravity frame, once for the sweep, the test and the polish.
  const std::vector<HorizontalNormal> horizontal =
      horizontalNormals(unit_normals, gravity.up, gravity.x_h, gravity.y_h, cos_delta);
  ManhattanFrameEstimator::Result mf;
  double yaw_rad = 0.0;
  if (mf_config.gravity_constrained) {
    // ManhattanFrameEstimator::estimateYaw on the same normals.
    yaw_rad = foldYaw(sweepArcs(horizontal).psi);
  } else {
    // Sec. 3.3 "R converted to R'": the unconstrained frame's most horizontal axis, projected on
    // the floor plane, gives the yaw of the gravity-aligned frame.
    mf = manhattan_.estimateSO3(normals);
    int most_horizontal = 0;
    for (int j = 1; j < 3; ++j) {
      if (std::abs(mf.R_W_MF.col(j).dot(gravity.up)) <
          std::abs(mf.R_W_MF.col(most_horizontal).dot(gravity.up))) {
        most_horizontal = j;
      }
    }
    yaw_rad = foldYaw(gravity.yawOf(mf.R_W_MF.col(most_horizontal)));
  }
  if (hasHorizontalStructure(horizontal, yaw_rad)) {
    // Eq. 3's count is flat over a few degrees around its maximum: polish on the inliers.
    yaw_rad = polishYaw(horizontal, yaw_rad, cos_delta);
    if (config_.footprint_yaw_area_ratio > 0.0) {
      // A yaw that rests on a few normals (cups on a table top, the edge of a chair back) can be
      // far off; its box then covers much more floor than the points need. The footprint's
      // minimum-area rectangle replaces it when that is clearly tighter.
      const std::vector<Eigen::Vector2d> outline = footprintStripEnds(footprint());
      const Rectangle2d tight = minimumAreaRectangle(outline);
      // Only an elongated footprint fixes a yaw (a square seat's rectangle fits at any yaw). The
      // yaws are in the footprint coordinates (x_h, y_h), as GravityFrame::rotationFromYaw's.
      if (tight.size.maxCoeff() >= kMinFootprintAspect * tight.size.minCoeff() &&
          tight.size.prod() < config_.footprint_yaw_area_ratio * rectangleArea(outline, yaw_rad)) {
        const double footprint_yaw = foldYaw(tight.yaw_rad);
        yaw_rad = footprint_yaw;
      }
    }
  } else {
    // Degenerate normals (cylinders, flat slabs, tiny clouds, a table top seen from above): the
    // minimum-area footprint instead.
    yaw_rad = minimumAreaYaw(footprint());
  }
  // The reported frame is the one the box uses (R' of Sec. 3.3), with its own Eq. 3 count.
  mf.yaw_rad = yaw_rad;
  mf.R_W_MF = gravity.rotationFromYaw(yaw_rad);
  mf.inliers = countInliersUnit(unit_normals, mf.R_W_MF, cos_delta);
  mf.num_normals = static_cast<int>(unit_normals.size());

  // Eq. 4: the frame at the centroid, the points expressed in it, min/max per axis.
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3f& p : points) centroid += p.cast<double>();
  centroid /= static_cast<double>(points.size());
  const Eigen::Matrix3d R_MF_W = mf.R_W_MF.transpose();
  Eigen::Vector3d min_MF = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d max_MF = -min_MF;
  const size_t trim = static_cast<size_t>(config_.extent_trim_fraction * points.size());
  if (trim == 0) {
    for (const Eigen::Vector3f& p : points) {
      const Eigen::Vector3d p_MF = R_MF_W * (p.cast<double>() - centroid);
      min_MF = min_MF.cwiseMin(p_MF);
      max_MF = max_MF.cwiseMax(p_MF);
    }
  } else {
    // Order statistics per axis: the trim-th smallest and largest coordinate.
    std::vector<double> coordinate(points.size());
    for (int axis = 0; axis < 3; ++axis) {
      const Eigen::Vector3d direction = R_MF_W.row(axis).transpose();
      for (size_t i = 0; i < points.size(); ++i) {
        coordinate[i] = direction.dot(points[i].cast<double>() - centroid);
      }
      std::nth_element(coordinate.begin(), coordinate.begin() + trim, coordinate.end());
      min_MF[axis] = coordinate[trim];
      std::nth_element(coordinate.begin(), coordinate.end() - 1 - trim, coordinate.end());
      max_MF[axis] = coordinate[coordinate.size() - 1 - trim];
    }
  }
  box->rotation = mf.R_W_MF;
  box->size_m = max_MF - min_MF;
  box->center_m = centroid + mf.R_W_MF * (0.5 * (min_MF + max_MF));
  if (frame != nullptr) *frame = mf;
  return Status::Ok();
}

}  // namespace mvod
