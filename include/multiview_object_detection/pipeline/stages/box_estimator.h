// Sec. 3.3, Eq. 4: a cloud's gravity-aligned oriented box, its yaw from the Manhattan frame of the
// surface normals (Eq. 3), or from the footprint where the normals carry none.
#pragma once

#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/stages/manhattan_frame.h"
#include "multiview_object_detection/pipeline/types/oriented_box.h"

namespace mvod {

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
  // The gravity-aligned frame (R' of Sec. 3.3) of the normals, with its Eq. 3 count: Eq. 3's yaw
  // (gravity-constrained, or from the SO(3) frame) polished, or replaced by the footprint's
  // minimum-area yaw where that is clearly tighter or the normals carry no horizontal structure.
  ManhattanFrameEstimator::Result gravityAlignedFrame(const PointCloud& points,
                                                      const std::vector<Eigen::Vector3f>& normals,
                                                      const GravityFrame& gravity) const;
  // The yaw of R' from the unconstrained (SO(3)) Manhattan frame: its most horizontal axis.
  double yawFromSO3(const std::vector<Eigen::Vector3f>& normals, const GravityFrame& gravity,
                    ManhattanFrameEstimator::Result* mf) const;

  Config config_;
  ManhattanFrameEstimator manhattan_;
};

}  // namespace mvod
