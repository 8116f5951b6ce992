// Sec. 3.3, Eq. 3: the Manhattan frame of a cloud's surface normals, gravity-constrained (a yaw
// about the floor normal, found exactly) or over SO(3).
#pragma once

#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/oriented_box.h"

namespace mvod {

class ManhattanFrameEstimator {
 public:
  struct Config {
    double inlier_angle_deg = 10.0;  // δ of Eq. 3
    double normal_radius_m = 0.03;
    int max_normals = 5000;  // normals subsampled beyond this (deterministic stride)
    // true (default): one axis is forced parallel to the floor normal and only yaw is searched,
    // solved exactly. false: the unconstrained SO(3) estimate, then the axis closest to vertical is
    // snapped to it.
    bool gravity_constrained = true;
    Status isValid() const;
    std::string print() const;
  };

  struct Result {
    Eigen::Matrix3d R_W_MF = Eigen::Matrix3d::Identity();  // columns: frame axes in world
    double yaw_rad = 0.0;  // yaw of column 0 about `up` (GravityFrame), in [-pi/4, pi/4)
    int inliers = 0;       // Eq. 3 objective at the optimum
    int num_normals = 0;
  };

  ManhattanFrameEstimator() = default;
  explicit ManhattanFrameEstimator(const Config& config) : config_(config) {}
  const Config& config() const { return config_; }

  // Eq. 3 with R restricted to rotations about `gravity.up`: the inlier count is a
  // piecewise-constant function of yaw in [0, pi/2) (the four horizontal axes fold onto one
  // period); each normal contributes an arc, and a sweep over the sorted arc end points finds the
  // global maximum exactly. Returns the middle of the best arc. Normals within δ of vertical count
  // for every yaw.
  Result estimateYaw(const std::vector<Eigen::Vector3f>& normals_W,
                     const GravityFrame& gravity) const;
  // Eq. 3 over SO(3): candidate first axes from the normals themselves, each completed by the exact
  // yaw search about it; the best consensus wins.
  Result estimateSO3(const std::vector<Eigen::Vector3f>& normals_W) const;
  // Eq. 3 objective: number of normals within δ of one of the six axes ±R e_j.
  int countInliers(const std::vector<Eigen::Vector3f>& normals, const Eigen::Matrix3d& R) const;

 private:
  Config config_;
};

// The parts of the gravity-constrained search that BoxEstimator runs on its own normals: there the
// sweep, the structure test and the polish share one HorizontalNormal per normal.
namespace manhattan {

// cos δ of Eq. 3.
double cosInlierAngle(double inlier_angle_deg);
// Folds a yaw into [-pi/4, pi/4): the four horizontal axes of a gravity-aligned frame are
// equivalent.
double foldYaw(double yaw_rad);
// Deterministic stride so that at most max_count of n items are kept.
int strideFor(std::size_t n, int max_count);
// Finite, non-zero normals (normalised, double), subsampled by stride to at most max_normals.
std::vector<Eigen::Vector3d> unitNormals(const std::vector<Eigen::Vector3f>& normals,
                                         int max_normals);

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
std::vector<HorizontalNormal> horizontalNormals(const std::vector<Eigen::Vector3d>& unit_normals,
                                                const Eigen::Vector3d& up,
                                                const Eigen::Vector3d& x_h,
                                                const Eigen::Vector3d& y_h, double cos_delta);

struct YawSweepResult {
  double psi = 0.0;  // in [0, pi/2)
  int inliers = 0;
};
// Exact maximiser of the gravity-constrained Eq. 3 over yaw: each normal is an inlier on a closed
// arc of yaw (mod 90°); a sweep over the sorted arc end points visits every piece of the
// piecewise-constant count. Among the maximal pieces the widest wins and its middle is returned.
YawSweepResult sweepArcs(const std::vector<HorizontalNormal>& normals);

// Eq. 3's count is flat over a few degrees around its maximum: the yaw moves to the mean (folded)
// horizontal angle of the normals that are inliers of a horizontal axis, repeated a few times (a
// flat-kernel mean shift).
double polishYaw(const std::vector<HorizontalNormal>& normals, double yaw_rad, double cos_delta);

// True if, at this yaw, the horizontal inliers clearly stand out from their average over all yaws
// (a cylinder or a flat slab gives a nearly flat inlier-vs-yaw curve): the Manhattan yaw is then
// meaningful.
bool hasHorizontalStructure(const std::vector<HorizontalNormal>& normals, double yaw_rad);

// Eq. 3 objective on unit normals: how many lie within δ (cos_delta) of one of the axes ±R e_j.
int countInliers(const std::vector<Eigen::Vector3d>& unit_normals, const Eigen::Matrix3d& R,
                 double cos_delta);

}  // namespace manhattan
}  // namespace mvod
