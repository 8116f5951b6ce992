#include "multiview_object_detection/pipeline/stages/manhattan_frame.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>

#include "multiview_object_detection/pipeline/types/parameter_ranges.h"
#include "multiview_object_detection/pipeline/utils/radix_sort.h"

namespace mvod {

using manhattan::foldYaw;
using manhattan::HorizontalNormal;
using manhattan::horizontalNormals;
using manhattan::strideFor;
using manhattan::sweepArcs;
using manhattan::unitNormals;
using manhattan::YawArc;
using manhattan::YawSweepResult;

namespace {

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
// falls back to the minimum-area footprint (hasHorizontalStructure).
constexpr double kMinPeakToMeanRatio = 1.5;
constexpr int kMinHorizontalInliers = 5;

// Folds an angle into [0, pi/2).
double foldQuarter(double angle) {
  double a = fmodSmall(angle, kHalfPi);
  if (a < 0.0) a += kHalfPi;
  if (a >= kHalfPi) a -= kHalfPi;
  return a;
}

template <typename T>
std::vector<T> strided(const std::vector<T>& items, int max_count) {
  const int stride = strideFor(items.size(), max_count);
  if (stride == 1) return items;
  std::vector<T> result;
  for (size_t i = 0; i < items.size(); i += stride) result.push_back(items[i]);
  return result;
}

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

}  // namespace

namespace manhattan {

double cosInlierAngle(double inlier_angle_deg) { return std::cos(inlier_angle_deg * kPi / 180.0); }

double foldYaw(double yaw_rad) {
  const double a = foldQuarter(yaw_rad);
  return a >= kQuarterPi ? a - kHalfPi : a;
}

int strideFor(std::size_t n, int max_count) {
  if (max_count <= 0 || n <= static_cast<std::size_t>(max_count)) return 1;
  return static_cast<int>((n + max_count - 1) / max_count);
}

std::vector<Eigen::Vector3d> unitNormals(const std::vector<Eigen::Vector3f>& normals,
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

int countInliers(const std::vector<Eigen::Vector3d>& unit_normals, const Eigen::Matrix3d& R,
                 double cos_delta) {
  int count = 0;
  for (const Eigen::Vector3d& n : unit_normals) count += isInlier(n, R, cos_delta) ? 1 : 0;
  return count;
}

// polishFrame for a gravity-aligned frame (a flat-kernel mean shift of the yaw).
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

// See kMinPeakToMeanRatio.
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

}  // namespace manhattan

Status ManhattanFrameEstimator::Config::isValid() const {
  // Above 45° the six axes' cones overlap and Eq. 3 stops distinguishing orientations.
  if (!(std::isfinite(inlier_angle_deg) && inlier_angle_deg > 0.0 && inlier_angle_deg <= 45.0)) {
    return Status::Error("manhattan inlier_angle_deg must be in (0, 45] (got " +
                         std::to_string(inlier_angle_deg) + ")");
  }
  if (Status s = checkParameterRange("box/normal_radius_m", normal_radius_m); !s) return s;
  if (Status s = checkParameterRange("box/max_normals", max_normals); !s) return s;
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
  const double cos_delta = manhattan::cosInlierAngle(config_.inlier_angle_deg);
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
  const double cos_delta = manhattan::cosInlierAngle(config_.inlier_angle_deg);
  const std::vector<Eigen::Vector3d> normals = unitNormals(normals_W, config_.max_normals);
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
  const double cos_delta = manhattan::cosInlierAngle(config_.inlier_angle_deg);
  const std::vector<Eigen::Vector3d> normals = unitNormals(normals_W, config_.max_normals);
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
    const int count = manhattan::countInliers(normals, R, cos_delta);
    if (count > best_count) {
      best_count = count;
      result.R_W_MF = R;
      result.yaw_rad = foldYaw(GravityFrame(-R.col(2)).yawOf(R.col(0)));
    }
  }
  result.inliers = best_count;
  return result;
}

}  // namespace mvod
