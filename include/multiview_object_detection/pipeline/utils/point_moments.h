// Zeroth, first and second moments of a multiset of points: sums that add, so a neighbourhood's
// covariance can be assembled from precomputed parts (cells, voxels) instead of from its points.
#pragma once

#include <Eigen/Core>

namespace mvod {

struct PointMoments {
  double n = 0.0;
  double x = 0.0, y = 0.0, z = 0.0;
  double xx = 0.0, xy = 0.0, xz = 0.0, yy = 0.0, yz = 0.0, zz = 0.0;

  // p relative to an origin common to all the moments that will be added together (precision).
  void add(const Eigen::Vector3d& p) {
    n += 1.0;
    x += p.x();
    y += p.y();
    z += p.z();
    xx += p.x() * p.x();
    xy += p.x() * p.y();
    xz += p.x() * p.z();
    yy += p.y() * p.y();
    yz += p.y() * p.z();
    zz += p.z() * p.z();
  }
  void add(const PointMoments& m) {
    n += m.n;
    x += m.x;
    y += m.y;
    z += m.z;
    xx += m.xx;
    xy += m.xy;
    xz += m.xz;
    yy += m.yy;
    yz += m.yz;
    zz += m.zz;
  }
  // The (biased) covariance; zero for no points.
  Eigen::Matrix3d covariance() const {
    Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
    if (!(n > 0.0)) return c;
    const Eigen::Vector3d mean(x / n, y / n, z / n);
    c(0, 0) = xx / n - mean.x() * mean.x();
    c(0, 1) = xy / n - mean.x() * mean.y();
    c(0, 2) = xz / n - mean.x() * mean.z();
    c(1, 1) = yy / n - mean.y() * mean.y();
    c(1, 2) = yz / n - mean.y() * mean.z();
    c(2, 2) = zz / n - mean.z() * mean.z();
    c(1, 0) = c(0, 1);
    c(2, 0) = c(0, 2);
    c(2, 1) = c(1, 2);
    return c;
  }
};

}  // namespace mvod
