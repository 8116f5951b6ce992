#include "multiview_object_detection/pipeline/stages/box_estimator.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <sstream>

#include "multiview_object_detection/pipeline/stages/normal_estimation.h"
#include "multiview_object_detection/pipeline/types/parameter_ranges.h"

namespace mvod {
namespace {

using manhattan::foldYaw;

// The footprint's minimum-area yaw is trusted only for a footprint this elongated (long / short).
constexpr double kMinFootprintAspect = 1.5;

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

// The footprint, projected when first needed (only some boxes need it).
class LazyFootprint {
 public:
  LazyFootprint(const PointCloud& points_W, const GravityFrame& gravity)
      : points_W_(points_W), gravity_(gravity) {}
  const Footprint& get() {
    if (!projected_) projected_ = projectFootprint(points_W_, gravity_);
    return *projected_;
  }

 private:
  const PointCloud& points_W_;
  const GravityFrame& gravity_;
  std::optional<Footprint> projected_;
};

// A yaw that rests on a few normals (cups on a table top, the edge of a chair back) can be far
// off; its box then covers much more floor than the points need. The footprint's minimum-area
// rectangle replaces it when that is clearly tighter: less than area_ratio of the area at yaw_rad.
// Only an elongated footprint fixes a yaw (a square seat's rectangle fits at any yaw). The yaws are
// in the footprint coordinates (x_h, y_h), as GravityFrame::rotationFromYaw's.
double tighterFootprintYaw(const Footprint& footprint, double yaw_rad, double area_ratio) {
  const std::vector<Eigen::Vector2d> outline = footprintStripEnds(footprint);
  const Rectangle2d tight = minimumAreaRectangle(outline);
  if (tight.size.maxCoeff() >= kMinFootprintAspect * tight.size.minCoeff() &&
      tight.size.prod() < area_ratio * rectangleAtYaw(outline, yaw_rad).area()) {
    return foldYaw(tight.yaw_rad);
  }
  return yaw_rad;
}

// Eq. 4: the frame R_W_MF at the centroid, the points expressed in it, min/max per axis (the
// trim_fraction-th order statistics at either end where that leaves out any point).
void fitExtents(const PointCloud& points, const Eigen::Matrix3d& R_W_MF, double trim_fraction,
                OrientedBox* box) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3f& p : points) centroid += p.cast<double>();
  centroid /= static_cast<double>(points.size());
  const Eigen::Matrix3d R_MF_W = R_W_MF.transpose();
  Eigen::Vector3d min_MF = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d max_MF = -min_MF;
  const size_t trim = static_cast<size_t>(trim_fraction * points.size());
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
  box->rotation = R_W_MF;
  box->size_m = max_MF - min_MF;
  box->center_m = centroid + R_W_MF * (0.5 * (min_MF + max_MF));
}

}  // namespace

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
  if (Status s = checkParameterRange("box/outline_cell_m", outline_cell_m); !s) return s;
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
  const int stride = manhattan::strideFor(points.size(), mf_config.max_normals);
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
          ? estimateCellNormalsAt(points, queries, radius_m, config_.num_threads)
          : estimateNormalsAt(points, queries, radius_m, max_neighbours, config_.num_threads);
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
  const ManhattanFrameEstimator::Result mf = gravityAlignedFrame(points, normals, gravity);
  fitExtents(points, mf.R_W_MF, config_.extent_trim_fraction, box);
  if (frame != nullptr) *frame = mf;
  return Status::Ok();
}

ManhattanFrameEstimator::Result BoxEstimator::gravityAlignedFrame(
    const PointCloud& points, const std::vector<Eigen::Vector3f>& normals,
    const GravityFrame& gravity) const {
  const ManhattanFrameEstimator::Config& mf_config = config_.manhattan;
  const double cos_delta = manhattan::cosInlierAngle(mf_config.inlier_angle_deg);
  LazyFootprint footprint(points, gravity);
  // The surface normals, and in the gravity-constrained search those of the footprint's outline.
  std::vector<Eigen::Vector3f> with_outline;
  if (mf_config.gravity_constrained && config_.outline_cell_m > 0.0) {
    with_outline = normals;
    const std::vector<Eigen::Vector3f> outline =
        outlineNormals(footprint.get(), gravity, config_.outline_cell_m);
    with_outline.insert(with_outline.end(), outline.begin(), outline.end());
  }
  const std::vector<Eigen::Vector3f>& eq3_normals = with_outline.empty() ? normals : with_outline;
  const std::vector<Eigen::Vector3d> unit_normals =
      manhattan::unitNormals(eq3_normals, mf_config.max_normals);
  // Their horizontal geometry in the gravity frame, once for the sweep, the test and the polish.
  const std::vector<manhattan::HorizontalNormal> horizontal =
      manhattan::horizontalNormals(unit_normals, gravity.up, gravity.x_h, gravity.y_h, cos_delta);
  ManhattanFrameEstimator::Result mf;
  // ManhattanFrameEstimator::estimateYaw on the same normals, or Sec. 3.3's R'.
  double yaw_rad = mf_config.gravity_constrained ? foldYaw(manhattan::sweepArcs(horizontal).psi)
                                                 : yawFromSO3(normals, gravity, &mf);
  if (manhattan::hasHorizontalStructure(horizontal, yaw_rad)) {
    // Eq. 3's count is flat over a few degrees around its maximum: polish on the inliers.
    yaw_rad = manhattan::polishYaw(horizontal, yaw_rad, cos_delta);
    if (config_.footprint_yaw_area_ratio > 0.0) {
      yaw_rad = tighterFootprintYaw(footprint.get(), yaw_rad, config_.footprint_yaw_area_ratio);
    }
  } else {
    // Degenerate normals (cylinders, flat slabs, tiny clouds, a table top seen from above): the
    // minimum-area footprint instead.
    yaw_rad = minimumAreaYaw(footprint.get());
  }
  // The reported frame is the one the box uses (R' of Sec. 3.3), with its own Eq. 3 count.
  mf.yaw_rad = yaw_rad;
  mf.R_W_MF = gravity.rotationFromYaw(yaw_rad);
  mf.inliers = manhattan::countInliers(unit_normals, mf.R_W_MF, cos_delta);
  mf.num_normals = static_cast<int>(unit_normals.size());
  return mf;
}

double BoxEstimator::yawFromSO3(const std::vector<Eigen::Vector3f>& normals,
                                const GravityFrame& gravity,
                                ManhattanFrameEstimator::Result* mf) const {
  // Sec. 3.3 "R converted to R'": the unconstrained frame's most horizontal axis, projected on
  // the floor plane, gives the yaw of the gravity-aligned frame.
  *mf = manhattan_.estimateSO3(normals);
  int most_horizontal = 0;
  for (int j = 1; j < 3; ++j) {
    if (std::abs(mf->R_W_MF.col(j).dot(gravity.up)) <
        std::abs(mf->R_W_MF.col(most_horizontal).dot(gravity.up))) {
      most_horizontal = j;
    }
  }
  return foldYaw(gravity.yawOf(mf->R_W_MF.col(most_horizontal)));
}

}  // namespace mvod
