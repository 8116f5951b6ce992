// Sec. 3.3: Manhattan frame (Eq. 3) from surface normals and the oriented box (Eq. 4).
#pragma once

#include <string>

#include "multiview_object_detection/pipeline/types/oriented_box.h"

namespace mvod {

// Surface normals by PCA over neighbours within radius_m (at most max_neighbours); unit length,
// oriented arbitrarily. Points with fewer than 3 neighbours get a NaN normal.
std::vector<Eigen::Vector3f> estimateNormals(const PointCloud& points, double radius_m,
                                             int max_neighbours = 30);

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

class BoxEstimator {
 public:
  struct Config {
    ManhattanFrameEstimator::Config manhattan;
    int min_points = 10;  // fewer points: no box
    // Robust extents: this fraction of the points is left out at each end of every axis (noisy
    // Kinect points add 4-6 cm to min/max). 0 = Eq. 4's min/max.
    double extent_trim_fraction = 0.005;
    // Depth resolution of the sensor, Δz = depth_step_per_m2 · z² (Kinect v1's disparity steps:
    // 2.85e-3, 2.6 cm at 3 m). Points of one view then lie on depth layers, and normals over a
    // radius smaller than the layer spacing point along the viewing ray: the normal radius grows to
    // 2 Δz at the view's median depth. 0 = fixed radius (the paper's method).
    double depth_step_per_m2 = 2.85e-3;
    // The footprint's minimum-area yaw replaces Eq. 3's when its rectangle (trimmed extents) has
    // less than this fraction of the area Eq. 3's yaw gives. A table seen from above is mostly top:
    // its few vertical normals (cups, edges, chair backs) gave the real redkitchen table a yaw 31°
    // off and a footprint 1.4 times too large. 0 = Eq. 3's yaw whenever its peak stands out (the
    // paper's).
    double footprint_yaw_area_ratio = 0.8;
    // Eq. 3 also counts the horizontal normals of the footprint's outline (the points' occupancy
    // on a horizontal grid of this cell size, its boundary's gradient directions): the edges of a
    // table top seen from above carry its yaw where its own normals, all vertical, carry none.
    // 0 = the surface normals only (the paper's).
    double outline_cell_m = 0.02;
    // How a single view's normals are estimated (Eq. 3's input). "cells": from the summed moments
    // of the cells of half the normal radius whose centres lie within the radius of the query's
    // cell, one normal per cell; the cost does not grow with the radius, which grows with depth.
    // "radius": PCA over the points within the radius (the nearest ones beyond a cap), per point;
    // the paper's (PCL's normal estimation).
    std::string normal_estimation = "cells";
    // Threads for one cloud's normals (independent queries): the mapper sets its own num_threads
    // here, as for the outlier removal. The result does not depend on it.
    int num_threads = 1;
    Status isValid() const;
    std::string print() const;
  };

  BoxEstimator() = default;
  explicit BoxEstimator(const Config& config) : config_(config), manhattan_(config.manhattan) {}
  const Config& config() const { return config_; }

  // Eq. 4: Manhattan frame of the cloud (normals -> estimator), the frame put at the centroid, the
  // points expressed in it, min/max per axis. The returned box's third column is gravity.up; its
  // centre is the middle of the min/max extent (not the centroid).
  // normals_W (optional): the normals it used, one per point of points_W, unit length and oriented
  // arbitrarily; NaN where none was computed (beyond max_normals only a stride subsample has one).
  // view_depth_m: the points' median depth in the camera that saw them (one view), for the
  // depth-dependent normal radius; 0 = unknown or fused (the configured radius).
  Status estimate(const PointCloud& points_W, const GravityFrame& gravity, OrientedBox* box,
                  ManhattanFrameEstimator::Result* frame = nullptr,
                  std::vector<Eigen::Vector3f>* normals_W = nullptr,
                  double view_depth_m = 0.0) const;
  // The normal radius estimate() uses at that depth.
  double normalRadius(double view_depth_m) const;
  // The same box from normals the caller already has (any number, not tied to the points; NaN or
  // zero ones are ignored), e.g. the per-voxel normals kept by evidence fusion: no neighbour
  // search.
  Status estimateFromNormals(const PointCloud& points_W,
                             const std::vector<Eigen::Vector3f>& normals_W,
                             const GravityFrame& gravity, OrientedBox* box,
                             ManhattanFrameEstimator::Result* frame = nullptr) const;

 private:
  // The checks both estimates share; the finite points (and their indices in points_W, if asked).
  Status checkedInput(const std::string& caller, const PointCloud& points_W,
                      const GravityFrame& gravity, const OrientedBox* box, PointCloud* points,
                      std::vector<int>* source) const;
  // Eq. 3 on the normals, then Eq. 4 on the (finite) points.
  Status boxFromNormals(const PointCloud& points, const std::vector<Eigen::Vector3f>& normals,
                        const GravityFrame& gravity, OrientedBox* box,
                        ManhattanFrameEstimator::Result* frame) const;

  Config config_;
  ManhattanFrameEstimator manhattan_;
};

}  // namespace mvod
