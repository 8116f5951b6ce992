#include "multiview_object_detection/pipeline/stages/gravity_estimator.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <numeric>
#include <random>
#include <sstream>
#include <unordered_map>

#include "multiview_object_detection/pipeline/stages/manhattan_frame.h"
#include "multiview_object_detection/pipeline/stages/normal_estimation.h"
#include "multiview_object_detection/pipeline/stages/point_cloud_filter.h"
#include "multiview_object_detection/pipeline/types/parameter_ranges.h"

namespace mvod {
namespace {

// Fewer supporting voxels than this is never a floor, whatever the fraction.
constexpr int kMinPlanePoints = 10;
// RANSAC draws its 2nd and 3rd points near the 1st (within about this many voxels, in the
// neighbouring grid cells): a plane holding 10 % of the frame is then still hit often.
constexpr double kSampleCellVoxels = 6.0;
constexpr int kRefineRounds = 3;
constexpr std::uint32_t kRandomSeed = 42;  // deterministic estimates
// The surfaces' normals: PCA over this many voxels around each.
constexpr double kNormalRadiusVoxels = 3.0;
// The angles (degrees) within which a normal counts as along gravity or across it, one round each,
// narrowing as the estimate settles (Gupta et al. 2013 narrow theirs from 45 to 15 degrees).
constexpr std::array<double, 5> kSurfaceRoundsDeg = {45.0, 35.0, 25.0, 20.0, 15.0};

using CellKey = std::array<std::int64_t, 3>;
struct CellKeyHash {
  std::size_t operator()(const CellKey& key) const {
    std::size_t h = static_cast<std::size_t>(key[0]) * 73856093u;
    h ^= static_cast<std::size_t>(key[1]) * 19349663u;
    h ^= static_cast<std::size_t>(key[2]) * 83492791u;
    return h;
  }
};

CellKey cellOf(const Eigen::Vector3f& p, double cell_size_m) {
  return {static_cast<std::int64_t>(std::floor(p.x() / cell_size_m)),
          static_cast<std::int64_t>(std::floor(p.y() / cell_size_m)),
          static_cast<std::int64_t>(std::floor(p.z() / cell_size_m))};
}

struct CandidatePlane {
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();  // unit
  float offset = 0.0f;                               // normal . p + offset = 0
  int inliers = 0;
};

int countInliers(const PointCloud& points, const CandidatePlane& plane, float threshold_m,
                 std::vector<int>* inlier_indices) {
  if (inlier_indices != nullptr) inlier_indices->clear();
  int count = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (std::abs(plane.normal.dot(points[i]) + plane.offset) <= threshold_m) {
      ++count;
      if (inlier_indices != nullptr) inlier_indices->push_back(static_cast<int>(i));
    }
  }
  return count;
}

// Least-squares plane (smallest principal axis) through the given points.
bool fitPlane(const PointCloud& points, const std::vector<int>& indices, CandidatePlane* plane) {
  if (indices.size() < 3) return false;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const int i : indices) mean += points[i].cast<double>();
  mean /= static_cast<double>(indices.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const int i : indices) {
    const Eigen::Vector3d d = points[i].cast<double>() - mean;
    covariance += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
  if (solver.info() != Eigen::Success) return false;
  const Eigen::Vector3d normal = solver.eigenvectors().col(0);  // eigenvalues ascending
  if (!normal.allFinite()) return false;
  plane->normal = normal.normalized().cast<float>();
  plane->offset = static_cast<float>(-normal.normalized().dot(mean));
  return true;
}

// Gravity as the frame's surfaces agree on it (Gupta, Arbelaez and Malik, CVPR 2013, Sec. 3.1): the
// direction g nearest to the normals within `d` of it (floor, table and desk tops, shelves) and
// farthest from those within `d` of perpendicular (walls, cabinet fronts, screens), minimising
// sum_across (n.g)^2 + sum_along (1 - (n.g)^2): the smallest eigenvector of
// sum_across n n^T - sum_along n n^T. One plane alone (a keyboard on its feet, a ramp) no longer
// decides; starting from it, `d` narrows round by round. Returns how many normals lie along the
// result in the last round (0 when the rounds failed).
int alignWithSurfaces(const std::vector<Eigen::Vector3d>& normals, Eigen::Vector3d* down) {
  Eigen::Vector3d g = down->normalized();
  const auto countAlong = [&normals](const Eigen::Vector3d& axis, double cos_d) {
    int along = 0;
    for (const Eigen::Vector3d& n : normals) along += std::abs(n.dot(axis)) >= cos_d;
    return along;
  };
  for (const double d_deg : kSurfaceRoundsDeg) {
    const double cos_d = std::cos(d_deg * kPi / 180.0);
    const double sin_d = std::sin(d_deg * kPi / 180.0);
    Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
    for (const Eigen::Vector3d& n : normals) {
      const double c = std::abs(n.dot(g));
      if (c >= cos_d) {
        M -= n * n.transpose();
      } else if (c <= sin_d) {
        M += n * n.transpose();
      }
    }
    if (countAlong(g, cos_d) < kMinPlanePoints) return 0;
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(M);
    if (solver.info() != Eigen::Success) return 0;
    const Eigen::Vector3d next = solver.eigenvectors().col(0);  // eigenvalues ascending
    if (!next.allFinite()) return 0;
    g = next.dot(g) < 0.0 ? -next : next;
  }
  *down = g;
  return countAlong(g, std::cos(kSurfaceRoundsDeg.back() * kPi / 180.0));
}

}  // namespace

Status GravityEstimator::Config::isValid() const {
  if (!(std::isfinite(plane_distance_threshold_m) && plane_distance_threshold_m > 0.0)) {
    return Status::Error("plane_distance_threshold_m must be a finite value > 0 (got " +
                         std::to_string(plane_distance_threshold_m) + ")");
  }
  if (Status s = checkParameterRange("gravity/ransac_iterations", ransac_iterations); !s) return s;
  if (!(std::isfinite(max_tilt_from_camera_up_deg) && max_tilt_from_camera_up_deg > 0.0 &&
        max_tilt_from_camera_up_deg < 90.0)) {
    return Status::Error("max_tilt_from_camera_up_deg must be in (0, 90) (got " +
                         std::to_string(max_tilt_from_camera_up_deg) + ")");
  }
  if (!(std::isfinite(min_plane_fraction) && min_plane_fraction >= 0.0 &&
        min_plane_fraction <= 1.0)) {
    return Status::Error("min_plane_fraction must be in [0, 1] (got " +
                         std::to_string(min_plane_fraction) + ")");
  }
  if (Status s = checkParameterRange("gravity/voxel_size_m", voxel_size_m); !s) return s;
  return Status::Ok();
}

std::string GravityEstimator::Config::print() const {
  std::ostringstream out;
  out << "plane_distance_threshold_m: " << plane_distance_threshold_m << "\n"
      << "ransac_iterations: " << ransac_iterations << "\n"
      << "max_tilt_from_camera_up_deg: " << max_tilt_from_camera_up_deg << "\n"
      << "min_plane_fraction: " << min_plane_fraction << "\n"
      << "voxel_size_m: " << voxel_size_m << "\n";
  return out.str();
}

bool GravityEstimator::addFrame(const PointCloud& points_D, const Eigen::Isometry3d& T_W_D) {
  if (!config_.isValid() || !isValidPose(T_W_D)) return has_estimate_;
  // A uniform grid first, so that the near floor (dense in a depth image) does not outvote the
  // rest.
  const PointCloud voxels_D = PointCloudFilter::voxelize(points_D, config_.voxel_size_m);
  const int num_points = static_cast<int>(voxels_D.size());
  if (num_points < kMinPlanePoints) return has_estimate_;

  const double cell_size_m = kSampleCellVoxels * config_.voxel_size_m;
  std::unordered_map<CellKey, std::vector<int>, CellKeyHash> grid;
  for (int i = 0; i < num_points; ++i) grid[cellOf(voxels_D[i], cell_size_m)].push_back(i);

  const float threshold_m = static_cast<float>(config_.plane_distance_threshold_m);
  const float min_cos_to_up =
      static_cast<float>(std::cos(config_.max_tilt_from_camera_up_deg * kPi / 180.0));
  const Eigen::Vector3f up_D(0.0f, -1.0f, 0.0f);  // camera-up: -y of the optical frame
  auto isHorizontal = [&](const Eigen::Vector3f& normal) {
    return std::abs(normal.dot(up_D)) >= min_cos_to_up;
  };

  // RANSAC over planes facing camera-up; the one with most support wins.
  std::mt19937 rng(kRandomSeed);
  std::uniform_int_distribution<int> pick_first(0, num_points - 1);
  std::vector<int> candidates;
  CandidatePlane best;
  for (int iteration = 0; iteration < config_.ransac_iterations; ++iteration) {
    const int first = pick_first(rng);
    const Eigen::Vector3f& p0 = voxels_D[first];
    const CellKey center = cellOf(p0, cell_size_m);
    candidates.clear();
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = grid.find({center[0] + dx, center[1] + dy, center[2] + dz});
          if (it == grid.end()) continue;
          for (const int index : it->second) {
            if (index != first) candidates.push_back(index);
          }
        }
      }
    }
    if (candidates.size() < 2) continue;
    std::uniform_int_distribution<std::size_t> pick(0, candidates.size() - 1);
    const std::size_t a = pick(rng);
    std::size_t b = pick(rng);
    if (a == b) b = (b + 1) % candidates.size();
    const Eigen::Vector3f e1 = voxels_D[candidates[a]] - p0;
    const Eigen::Vector3f e2 = voxels_D[candidates[b]] - p0;
    const Eigen::Vector3f cross = e1.cross(e2);
    // Nearly collinear samples give no reliable normal.
    if (!(cross.norm() > 0.1f * e1.norm() * e2.norm())) continue;
    CandidatePlane plane;
    plane.normal = cross.normalized();
    if (!isHorizontal(plane.normal)) continue;
    plane.offset = -plane.normal.dot(p0);
    plane.inliers = countInliers(voxels_D, plane, threshold_m, nullptr);
    if (plane.inliers > best.inliers) best = plane;
  }
  if (best.inliers < 3) return has_estimate_;

  // Least-squares refit on the inliers, a few rounds. A refit that leaves the cone means the
  // hypothesis was a slanted cut through a steeper plane (a floor seen from a steep camera), not a
  // horizontal plane: no estimate from this frame.
  std::vector<int> inliers;
  countInliers(voxels_D, best, threshold_m, &inliers);
  for (int round = 0; round < kRefineRounds; ++round) {
    CandidatePlane refined;
    if (!fitPlane(voxels_D, inliers, &refined)) break;
    if (!isHorizontal(refined.normal)) return has_estimate_;
    std::vector<int> refined_inliers;
    refined.inliers = countInliers(voxels_D, refined, threshold_m, &refined_inliers);
    if (refined.inliers < best.inliers) break;
    best = refined;
    inliers.swap(refined_inliers);
  }

  const int min_support = std::max(
      kMinPlanePoints, static_cast<int>(std::ceil(config_.min_plane_fraction * num_points)));
  if (best.inliers < min_support) return has_estimate_;

  // Gravity starts as the plane's normal on the side of camera +y (down), then is what all the
  // frame's surfaces agree on. A frame whose surfaces do not agree (fewer than min_plane_fraction
  // of its normals within 15 degrees of the result: the plane was a slanted cut through clutter,
  // not a surface) or that leaves the cone gives no estimate.
  Eigen::Vector3d down_D = best.normal.cast<double>();
  if (down_D.y() < 0.0) down_D = -down_D;
  std::vector<int> all(voxels_D.size());
  std::iota(all.begin(), all.end(), 0);
  const int along = alignWithSurfaces(
      manhattan::unitNormals(
          estimateCellNormalsAt(voxels_D, all, kNormalRadiusVoxels * config_.voxel_size_m),
          std::numeric_limits<int>::max()),
      &down_D);
  if (along < min_support || !isHorizontal(down_D.cast<float>())) return has_estimate_;
  const Eigen::Vector3d down_W = (T_W_D.linear() * down_D).normalized();
  if (!down_W.allFinite()) return has_estimate_;
  // Keep the best-supported frame's estimate: one clear floor beats many glimpses of a table.
  if (best.inliers > best_support_) {
    gravity_W_ = down_W;
    best_support_ = best.inliers;
    has_estimate_ = true;
  }
  return has_estimate_;
}

}  // namespace mvod
