// Sec. 3.3: normals, the Manhattan frame (Eq. 3, gravity-constrained and over SO(3)) and the
// oriented box (Eq. 4), on synthetic clouds.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <iostream>
#include <random>

#include "multiview_object_detection/pipeline/stages/box_estimator.h"
#include "multiview_object_detection/pipeline/stages/manhattan_frame.h"
#include "multiview_object_detection/pipeline/stages/normal_estimation.h"

namespace mvod {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// Points uniformly on the six faces of a box (area-weighted), in the box frame.
PointCloud sampleBoxSurface(const Eigen::Vector3d& size_m, int num_points, std::mt19937* rng) {
  const double areas[3] = {size_m.y() * size_m.z(), size_m.x() * size_m.z(),
                           size_m.x() * size_m.y()};
  std::discrete_distribution<int> face_axis({areas[0], areas[1], areas[2]});
  std::uniform_real_distribution<double> unit(-0.5, 0.5);
  std::bernoulli_distribution side(0.5);
  PointCloud points;
  for (int i = 0; i < num_points; ++i) {
    const int axis = face_axis(*rng);
    Eigen::Vector3d p(unit(*rng) * size_m.x(), unit(*rng) * size_m.y(), unit(*rng) * size_m.z());
    p[axis] = (side(*rng) ? 0.5 : -0.5) * size_m[axis];
    points.push_back(p.cast<float>());
  }
  return points;
}

PointCloud transformed(const PointCloud& points, const Eigen::Matrix3d& R,
                       const Eigen::Vector3d& t) {
  PointCloud out;
  for (const Eigen::Vector3f& p : points) out.push_back((R * p.cast<double>() + t).cast<float>());
  return out;
}

void addNoise(double sigma_m, PointCloud* points, std::mt19937* rng) {
  std::normal_distribution<float> noise(0.0f, static_cast<float>(sigma_m));
  for (Eigen::Vector3f& p : *points) p += Eigen::Vector3f(noise(*rng), noise(*rng), noise(*rng));
}

// Difference of two yaws modulo 90° (the four horizontal axes are equivalent), in degrees.
double yawErrorDeg(double a_rad, double b_rad) {
  double d = std::fmod(std::abs(a_rad - b_rad), 90.0 * kDeg);
  return std::min(d, 90.0 * kDeg - d) / kDeg;
}

Eigen::Vector3d randomUnit(std::mt19937* rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  return Eigen::Vector3d(g(*rng), g(*rng), g(*rng)).normalized();
}

// A noisy box cloud (5 mm) rotated by `yaw` about gravity.up, with outliers drawn uniformly in its
// bounding volume so that they make up `outlier_fraction` of the cloud.
PointCloud noisyBoxWithOutliers(const GravityFrame& gravity, double yaw_rad,
                                double outlier_fraction, std::mt19937* rng) {
  const Eigen::Vector3d size(0.8, 0.5, 0.6);
  const Eigen::Vector3d center(1.0, -2.0, 0.5);
  const int num_inliers = 14000;
  PointCloud points = transformed(sampleBoxSurface(size, num_inliers, rng),
                                  gravity.rotationFromYaw(yaw_rad), center);
  addNoise(0.005, &points, rng);
  const int num_outliers =
      static_cast<int>(std::round(num_inliers * outlier_fraction / (1.0 - outlier_fraction)));
  Eigen::Vector3f lo = points.front(), hi = points.front();
  for (const Eigen::Vector3f& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < num_outliers; ++i) {
    points.push_back(lo + Eigen::Vector3f(u(*rng), u(*rng), u(*rng)).cwiseProduct(hi - lo));
  }
  std::shuffle(points.begin(), points.end(), *rng);
  return points;
}

// ---------------------------------------------------------------------------------------------------

TEST(ManhattanNormals, PlaneNormalsMatchThePlane) {
  std::mt19937 rng(1);
  const Eigen::Vector3d normal = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
  const Eigen::Vector3d a = normal.unitOrthogonal();
  const Eigen::Vector3d b = normal.cross(a);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  PointCloud points;
  for (int i = 0; i < 3000; ++i) {
    points.push_back((Eigen::Vector3d(5, 5, 5) + u(rng) * a + u(rng) * b).cast<float>());
  }
  // Clean plane: every normal is the plane normal.
  std::vector<Eigen::Vector3f> normals = estimateNormals(points, 0.05);
  ASSERT_EQ(normals.size(), points.size());
  for (const Eigen::Vector3f& n : normals) {
    ASSERT_TRUE(n.allFinite());
    EXPECT_NEAR(n.norm(), 1.0, 1e-4);
    EXPECT_GT(std::abs(n.cast<double>().dot(normal)), std::cos(0.5 * kDeg));
  }
  // 1 mm noise: nearly all within 3° (border points with few neighbours may be worse).
  addNoise(0.001, &points, &rng);
  normals = estimateNormals(points, 0.05);
  int good = 0;
  for (const Eigen::Vector3f& n : normals) {
    good += std::abs(n.cast<double>().dot(normal)) > std::cos(3.0 * kDeg) ? 1 : 0;
  }
  EXPECT_GT(good, 0.95 * points.size());
}

TEST(ManhattanNormals, MatchesBruteForcePca) {
  // The hash-grid neighbour search must find exactly the radius neighbours: compare with brute
  // force.
  std::mt19937 rng(2);
  PointCloud points;
  for (int i = 0; i < 800; ++i) points.push_back((0.3 * randomUnit(&rng)).cast<float>());
  addNoise(0.01, &points, &rng);
  const double radius = 0.08;
  const std::vector<Eigen::Vector3f> normals = estimateNormals(points, radius, 100000);
  int checked = 0;
  for (size_t i = 0; i < points.size(); i += 7) {
    std::vector<Eigen::Vector3d> neighbours;
    for (const Eigen::Vector3f& q : points) {
      if ((q - points[i]).squaredNorm() <= radius * radius) neighbours.push_back(q.cast<double>());
    }
    if (neighbours.size() < 5) continue;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const auto& q : neighbours) mean += q;
    mean /= neighbours.size();
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const auto& q : neighbours) cov += (q - mean) * (q - mean).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(cov);
    ASSERT_TRUE(normals[i].allFinite());
    EXPECT_GT(std::abs(solver.eigenvectors().col(0).dot(normals[i].cast<double>())), 0.999);
    ++checked;
  }
  EXPECT_GT(checked, 50);
}

TEST(ManhattanNormals, DegenerateInputsGiveNaNNotCrashes) {
  EXPECT_TRUE(estimateNormals({}, 0.03).empty());
  // Isolated points, a NaN point, and bad radii.
  PointCloud points = {Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(1, 0, 0), Eigen::Vector3f(0, 1, 0),
                       Eigen::Vector3f(NAN, 0, 0)};
  for (double radius : {0.03, 0.0, -1.0, static_cast<double>(NAN)}) {
    const std::vector<Eigen::Vector3f> normals = estimateNormals(points, radius);
    ASSERT_EQ(normals.size(), points.size());
    for (const Eigen::Vector3f& n : normals) EXPECT_FALSE(n.allFinite());
  }
  // Collinear points have no plane.
  PointCloud line;
  for (int i = 0; i < 20; ++i) line.emplace_back(0.001f * i, 0.0f, 0.0f);
  for (const Eigen::Vector3f& n : estimateNormals(line, 0.05)) EXPECT_FALSE(n.allFinite());
  // Far from the origin the normals are still right.
  PointCloud far;
  for (int i = 0; i < 10; ++i) {
    for (int j = 0; j < 10; ++j) far.emplace_back(1000.0f + 0.01f * i, -500.0f + 0.01f * j, 7.0f);
  }
  for (const Eigen::Vector3f& n : estimateNormals(far, 0.03)) {
    ASSERT_TRUE(n.allFinite());
    EXPECT_GT(std::abs(n.z()), 0.99);
  }
}

// The cells' normals (BoxEstimator's default for single views) on the same degenerate inputs.
TEST(ManhattanNormals, CellNormalsOfDegenerateInputsAreNaNAndFarPlanesRight) {
  const GravityFrame gravity(Eigen::Vector3d(0, 0, -1));
  const BoxEstimator estimator{BoxEstimator::Config()};
  ASSERT_EQ(estimator.config().normal_estimation, "cells");
  OrientedBox box;
  std::vector<Eigen::Vector3f> normals;
  PointCloud line;
  for (int i = 0; i < 40; ++i) line.emplace_back(0.005f * i, 0.0f, 1.0f);
  estimator.estimate(line, gravity, &box, nullptr, &normals);  // a box or an error, no crash
  ASSERT_EQ(normals.size(), line.size());
  for (const Eigen::Vector3f& n : normals) EXPECT_FALSE(n.allFinite());
  PointCloud far;
  for (int i = 0; i < 30; ++i) {
    for (int j = 0; j < 30; ++j) far.emplace_back(1000.0f + 0.01f * i, -500.0f + 0.01f * j, 7.0f);
  }
  far.emplace_back(NAN, 0.0f, 0.0f);
  ASSERT_TRUE(estimator.estimate(far, gravity, &box, nullptr, &normals).ok());
  ASSERT_EQ(normals.size(), far.size());
  EXPECT_FALSE(normals.back().allFinite());
  for (std::size_t i = 0; i + 1 < normals.size(); ++i) {
    ASSERT_TRUE(normals[i].allFinite()) << i;
    EXPECT_GT(std::abs(normals[i].z()), 0.99);
  }
}

// ---------------------------------------------------------------------------------------------------

TEST(ManhattanConfig, ValidationAndPrint) {
  ManhattanFrameEstimator::Config config;
  EXPECT_TRUE(config.isValid().ok());
  config.inlier_angle_deg = 0.0;
  EXPECT_FALSE(config.isValid().ok());
  config.inlier_angle_deg = 60.0;
  EXPECT_FALSE(config.isValid().ok());
  config.inlier_angle_deg = 10.0;
  config.normal_radius_m = NAN;
  EXPECT_FALSE(config.isValid().ok());
  config.normal_radius_m = 0.03;
  config.max_normals = 0;
  EXPECT_FALSE(config.isValid().ok());

  BoxEstimator::Config box_config;
  EXPECT_TRUE(box_config.isValid().ok());
  const std::string text = box_config.print();
  EXPECT_NE(text.find("manhattan.inlier_angle_deg: 10\n"), std::string::npos);
  EXPECT_NE(text.find("manhattan.gravity_constrained: true\n"), std::string::npos);
  EXPECT_NE(text.find("min_points: 10\n"), std::string::npos);
  box_config.min_points = 0;
  EXPECT_FALSE(box_config.isValid().ok());
  box_config.min_points = 10;
  EXPECT_NE(text.find("normal_estimation: cells\n"), std::string::npos);
  box_config.normal_estimation = "pca";
  EXPECT_FALSE(box_config.isValid().ok());
  box_config.normal_estimation = "radius";
  EXPECT_TRUE(box_config.isValid().ok());
  box_config.manhattan.inlier_angle_deg = -1.0;
  EXPECT_FALSE(box_config.isValid().ok());
}

TEST(ManhattanCountInliers, CountsEachNormalOnceAndIgnoresNaN) {
  ManhattanFrameEstimator estimator;  // δ = 10°
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3f x = R.col(0).cast<float>();
  const Eigen::Vector3f z = R.col(2).cast<float>();
  const Eigen::Vector3f tilted_8 = (Eigen::AngleAxisd(8 * kDeg, R.col(1)) * R.col(0)).cast<float>();
  const Eigen::Vector3f tilted_12 =
      (Eigen::AngleAxisd(12 * kDeg, R.col(1)) * R.col(0)).cast<float>();
  const std::vector<Eigen::Vector3f> normals = {x,
                                                -x,
                                                2.0f * z,
                                                tilted_8,
                                                tilted_12,
                                                Eigen::Vector3f(NAN, 0, 0),
                                                Eigen::Vector3f::Zero(),
                                                (x + z).normalized()};
  EXPECT_EQ(estimator.countInliers(normals, R), 4);
}

TEST(ManhattanYaw, ExactSweepBeatsBruteForceScan) {
  std::mt19937 rng(3);
  const GravityFrame gravity(Eigen::Vector3d(0.2, -0.3, -1.0));
  // Random normals plus two loose clusters, so the objective has a non-trivial maximum.
  std::vector<Eigen::Vector3f> normals;
  for (int i = 0; i < 150; ++i) normals.push_back(randomUnit(&rng).cast<float>());
  std::normal_distribution<double> jitter(0.0, 6.0 * kDeg);
  for (int i = 0; i < 60; ++i) {
    const double yaw = (i % 2 ? 20.0 : 110.0) * kDeg + jitter(rng);
    const Eigen::Vector3d h = gravity.rotationFromYaw(yaw).col(0);
    normals.push_back(
        (Eigen::AngleAxisd(jitter(rng), gravity.up.cross(h).normalized()) * h).cast<float>());
  }
  normals.push_back(Eigen::Vector3f(NAN, NAN, NAN));

  for (double delta_deg : {10.0, 3.0, 25.0}) {
    ManhattanFrameEstimator::Config config;
    config.inlier_angle_deg = delta_deg;
    const ManhattanFrameEstimator estimator(config);
    const ManhattanFrameEstimator::Result result = estimator.estimateYaw(normals, gravity);
    int brute_best = 0;
    for (int step = 0; step < 9000; ++step) {
      brute_best = std::max(
          brute_best, estimator.countInliers(normals, gravity.rotationFromYaw(step * 0.01 * kDeg)));
    }
    EXPECT_GE(result.inliers, brute_best) << "delta " << delta_deg;
    EXPECT_EQ(estimator.countInliers(normals, result.R_W_MF), result.inliers);
    EXPECT_GE(result.yaw_rad, -45.0 * kDeg);
    EXPECT_LT(result.yaw_rad, 45.0 * kDeg);
    EXPECT_TRUE(result.R_W_MF.isApprox(gravity.rotationFromYaw(result.yaw_rad), 1e-12));
    EXPECT_EQ(result.num_normals, static_cast<int>(normals.size()) - 1);
    // Deterministic.
    EXPECT_EQ(estimator.estimateYaw(normals, gravity).yaw_rad, result.yaw_rad);
  }
}

TEST(ManhattanYaw, VerticalNormalsCountAtEveryYawAndArcsWrap) {
  ManhattanFrameEstimator estimator;
  const GravityFrame gravity;
  std::vector<Eigen::Vector3f> normals;
  // Horizontal normals at yaw 44°..46° and at -44°: the best yaw sits across the 45° fold.
  for (double yaw_deg : {44.0, 45.0, 46.0, -44.0, 134.0}) {
    normals.push_back(gravity.rotationFromYaw(yaw_deg * kDeg).col(0).cast<float>());
  }
  normals.emplace_back(0.0f, 0.05f, 1.0f);  // near up
  normals.emplace_back(0.0f, 0.0f, -1.0f);  // down
  const ManhattanFrameEstimator::Result result = estimator.estimateYaw(normals, gravity);
  EXPECT_EQ(result.inliers, 7);
  EXPECT_LT(yawErrorDeg(result.yaw_rad, 45.0 * kDeg), 10.0);
  EXPECT_EQ(estimator.countInliers(normals, result.R_W_MF), 7);

  // No usable normal: zero inliers, a valid rotation, no crash.
  const ManhattanFrameEstimator::Result empty = estimator.estimateYaw({}, gravity);
  EXPECT_EQ(empty.inliers, 0);
  EXPECT_NEAR(empty.R_W_MF.determinant(), 1.0, 1e-9);
}

TEST(ManhattanSO3, RecoversRandomRotationOfBoxNormals) {
  std::mt19937 rng(4);
  std::normal_distribution<double> jitter(0.0, 2.0 * kDeg);
  for (int trial = 0; trial < 5; ++trial) {
    std::normal_distribution<double> g(0.0, 1.0);
    const Eigen::Matrix3d R_true =
        Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix();
    std::vector<Eigen::Vector3f> normals;
    // Unequal face populations, 2° noise, 25% random outliers.
    const int per_axis[3] = {900, 500, 250};
    for (int j = 0; j < 3; ++j) {
      for (int i = 0; i < per_axis[j]; ++i) {
        const Eigen::Vector3d axis = (i % 2 ? 1.0 : -1.0) * R_true.col(j);
        const Eigen::Vector3d tilt = randomUnit(&rng).cross(axis).normalized();
        normals.push_back((Eigen::AngleAxisd(jitter(rng), tilt) * axis).cast<float>());
      }
    }
    for (int i = 0; i < 550; ++i) normals.push_back(randomUnit(&rng).cast<float>());
    std::shuffle(normals.begin(), normals.end(), rng);

    const ManhattanFrameEstimator estimator;
    const ManhattanFrameEstimator::Result result = estimator.estimateSO3(normals);
    EXPECT_NEAR(result.R_W_MF.determinant(), 1.0, 1e-9);
    EXPECT_TRUE((result.R_W_MF.transpose() * result.R_W_MF).isIdentity(1e-9));
    EXPECT_EQ(estimator.countInliers(normals, result.R_W_MF), result.inliers);
    EXPECT_GE(result.inliers, estimator.countInliers(normals, R_true));
    // Up to the 24 axis permutations/signs: each estimated axis matches some true axis within 2°.
    for (int j = 0; j < 3; ++j) {
      const double best_dot = (R_true.transpose() * result.R_W_MF.col(j)).cwiseAbs().maxCoeff();
      EXPECT_GT(best_dot, std::cos(2.0 * kDeg)) << "trial " << trial << " axis " << j;
    }
  }
  // Empty input: no crash, identity.
  const ManhattanFrameEstimator::Result empty = ManhattanFrameEstimator().estimateSO3({});
  EXPECT_EQ(empty.inliers, 0);
  EXPECT_TRUE(empty.R_W_MF.isIdentity());
}

// ---------------------------------------------------------------------------------------------------

TEST(ManhattanBox, YawWithin2DegOnNoisyBoxWith30PercentOutliers) {
  std::mt19937 rng(5);
  for (const Eigen::Vector3d& down :
       {Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(0.3, -0.2, -1.0), Eigen::Vector3d(0, -1, 0)}) {
    const GravityFrame gravity(down);
    const double yaw_true = 27.0 * kDeg;
    const PointCloud points = noisyBoxWithOutliers(gravity, yaw_true, 0.3, &rng);
    for (bool constrained : {true, false}) {
      for (const char* normals : {"cells", "radius"}) {
        BoxEstimator::Config config;
        config.manhattan.gravity_constrained = constrained;
        config.normal_estimation = normals;
        const BoxEstimator estimator(config);
        OrientedBox box;
        ManhattanFrameEstimator::Result frame;
        ASSERT_TRUE(estimator.estimate(points, gravity, &box, &frame).ok());
        EXPECT_LT(yawErrorDeg(frame.yaw_rad, yaw_true), 2.0)
            << "gravity " << down.transpose() << " constrained " << constrained << " normals "
            << normals;
        EXPECT_LT(yawErrorDeg(gravity.yawOf(box.rotation.col(0)), yaw_true), 2.0);
        EXPECT_TRUE(box.rotation.col(2).isApprox(gravity.up, 1e-9));
        EXPECT_GT(frame.inliers, frame.num_normals / 3);
      }
    }
  }
}

// One Kinect-like view of two faces of a box 4 m away, with the synthetic benchmark's sensor model:
// axial noise (2.6 cm here), then disparity steps (Δz = 2.85e-3 z², 4.6 cm here), so the faces
// are noisy terraces of constant depth. Normals over the fixed 3 cm radius see single terraces
// and point along the viewing ray; the radius grown to two depth steps sees the faces.
TEST(ManhattanBox, NormalRadiusGrowsWithTheViewsDepthSteps) {
  const GravityFrame gravity(Eigen::Vector3d(0, 0, -1));
  const double yaw_true = 30.0 * kDeg;
  const Eigen::Matrix3d R = gravity.rotationFromYaw(yaw_true);
  const Eigen::Vector3d centre(4.0, 0.3, 0.8);  // camera at the origin, optical axis along +x
  const double half = 0.4;
  const double k = 2.85e-3;
  std::mt19937 rng(11);
  std::normal_distribution<double> gauss(0.0, 1.0);
  PointCloud points;
  std::vector<Eigen::Vector3d> true_normals;
  // The two faces that look at the camera: -x and -y of the box frame at this yaw.
  for (const int axis : {0, 1}) {
    const Eigen::Vector3d normal = -R.col(axis);
    const Eigen::Vector3d along = R.col(1 - axis);
    for (double s = -half; s <= half; s += 0.01) {  // the filter's 1 cm grid
      for (double h = -0.8; h <= 0.8; h += 0.01) {
        const Eigen::Vector3d p = centre + half * normal + s * along + h * gravity.up;
        const double z = p.x();
        const double sigma_m = 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4);
        const double z_noisy = z + sigma_m * gauss(rng);
        const double z_quantised = 1.0 / (k * std::round(1.0 / (k * z_noisy)));
        points.push_back((p * (z_quantised / z)).cast<float>());
        true_normals.push_back(normal);
      }
    }
  }
  BoxEstimator::Config radius_config;
  radius_config.normal_estimation = "radius";  // per point; the cells' normals are checked below
  const BoxEstimator estimator(radius_config);
  EXPECT_DOUBLE_EQ(estimator.normalRadius(0.0), 0.03);
  EXPECT_NEAR(estimator.normalRadius(4.0), 2 * k * 16.0, 1e-12);
  EXPECT_LE(estimator.normalRadius(20.0), 0.15);  // capped

  const auto medianAngleDeg = [&](double view_depth_m, double* yaw_error_deg,
                                  const BoxEstimator& box_estimator) {
    OrientedBox box;
    ManhattanFrameEstimator::Result frame;
    std::vector<Eigen::Vector3f> normals;
    EXPECT_TRUE(box_estimator.estimate(points, gravity, &box, &frame, &normals, view_depth_m).ok());
    EXPECT_EQ(normals.size(), points.size());
    std::vector<double> angles;
    for (size_t i = 0; i < normals.size(); ++i) {
      if (!normals[i].allFinite()) continue;
      const double c = std::min(1.0, std::abs(normals[i].cast<double>().dot(true_normals[i])));
      angles.push_back(std::acos(c) / kDeg);
    }
    *yaw_error_deg = yawErrorDeg(frame.yaw_rad, yaw_true);
    std::nth_element(angles.begin(), angles.begin() + angles.size() / 2, angles.end());
    return angles[angles.size() / 2];
  };
  double fixed_yaw_error = 0.0;
  double grown_yaw_error = 0.0;
  const double fixed = medianAngleDeg(0.0, &fixed_yaw_error, estimator);
  const double grown = medianAngleDeg(4.0, &grown_yaw_error, estimator);
  EXPECT_GT(fixed, 20.0);
  EXPECT_LT(grown, 5.0);
  EXPECT_LT(grown_yaw_error, 2.0);
  // Cell moments (the default) on the same radii: the same picture.
  const BoxEstimator cells{BoxEstimator::Config()};
  double cells_fixed_yaw_error = 0.0;
  double cells_grown_yaw_error = 0.0;
  EXPECT_GT(medianAngleDeg(0.0, &cells_fixed_yaw_error, cells), 20.0);
  EXPECT_LT(medianAngleDeg(4.0, &cells_grown_yaw_error, cells), 5.0);
  EXPECT_LT(cells_grown_yaw_error, 2.0);
  std::cout << "median normal error: fixed radius " << fixed << " deg, grown " << grown
            << " deg; yaw error " << fixed_yaw_error << " / " << grown_yaw_error << " deg\n";

  // The normals split over threads (per point, and per cell): the same normals and box, bit for
  // bit.
  for (const BoxEstimator::Config& base : {radius_config, BoxEstimator::Config()}) {
    OrientedBox box_1;
    std::vector<Eigen::Vector3f> normals_1;
    ASSERT_TRUE(
        BoxEstimator(base).estimate(points, gravity, &box_1, nullptr, &normals_1, 4.0).ok());
    for (const int threads : {2, 3}) {
      BoxEstimator::Config config = base;
      config.num_threads = threads;
      OrientedBox box_n;
      std::vector<Eigen::Vector3f> normals_n;
      ASSERT_TRUE(
          BoxEstimator(config).estimate(points, gravity, &box_n, nullptr, &normals_n, 4.0).ok());
      ASSERT_EQ(normals_n.size(), normals_1.size());
      for (size_t i = 0; i < normals_1.size(); ++i) {
        ASSERT_TRUE(normals_n[i] == normals_1[i] ||
                    (!normals_n[i].allFinite() && !normals_1[i].allFinite()))
            << base.normal_estimation << ", point " << i << ", " << threads << " threads";
      }
      EXPECT_EQ(box_n.center_m, box_1.center_m);
      EXPECT_EQ(box_n.size_m, box_1.size_m);
      EXPECT_EQ(box_n.rotation, box_1.rotation);
    }
  }
}

TEST(ManhattanBox, SizeWithin2cmOnCleanBox) {
  std::mt19937 rng(6);
  const Eigen::Vector3d size(0.8, 0.5, 0.6);
  const Eigen::Vector3d center(-0.4, 1.2, 0.3);
  for (const Eigen::Vector3d& down :
       {Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(-0.2, 0.1, -1.0)}) {
    const GravityFrame gravity(down);
    const PointCloud points = transformed(sampleBoxSurface(size, 20000, &rng),
                                          gravity.rotationFromYaw(40.0 * kDeg), center);
    for (bool constrained : {true, false}) {
      BoxEstimator::Config config;
      config.manhattan.gravity_constrained = constrained;
      OrientedBox box;
      ASSERT_TRUE(BoxEstimator(config).estimate(points, gravity, &box).ok());
      EXPECT_TRUE(box.rotation.col(2).isApprox(gravity.up, 1e-9));
      EXPECT_NEAR(box.rotation.determinant(), 1.0, 1e-9);
      const double horizontal_min = std::min(box.size_m.x(), box.size_m.y());
      const double horizontal_max = std::max(box.size_m.x(), box.size_m.y());
      EXPECT_NEAR(horizontal_max, 0.8, 0.02) << "constrained " << constrained;
      EXPECT_NEAR(horizontal_min, 0.5, 0.02);
      EXPECT_NEAR(box.size_m.z(), 0.6, 0.02);
      EXPECT_LT((box.center_m - center).norm(), 0.01);
      for (size_t i = 0; i < points.size(); i += 97) {
        EXPECT_TRUE(box.contains(points[i].cast<double>(), 1e-4));
      }
    }
  }
}

TEST(ManhattanBox, CentreIsMiddleOfExtentNotCentroid) {
  // A box with one face densely sampled: the centroid is pulled off-centre, the box centre is not.
  std::mt19937 rng(7);
  const Eigen::Vector3d size(0.6, 0.4, 0.5);
  PointCloud points = sampleBoxSurface(size, 4000, &rng);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  for (int i = 0; i < 6000; ++i) {
    points.emplace_back(0.3f, static_cast<float>(u(rng) * 0.4), static_cast<float>(u(rng) * 0.5));
  }
  OrientedBox box;
  ASSERT_TRUE(BoxEstimator().estimate(points, GravityFrame(), &box).ok());
  EXPECT_LT(box.center_m.norm(), 0.01);
}

TEST(ManhattanBox, FlatSlabFallsBackToMinimumAreaFootprint) {
  // Only the top face of a rotated 0.9 x 0.3 table top: every normal is vertical, so Eq. 3 cannot
  // fix the yaw; the minimum-area footprint must.
  std::mt19937 rng(8);
  const GravityFrame gravity;
  const double yaw_true = 33.0 * kDeg;
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  PointCloud points;
  for (int i = 0; i < 3000; ++i) {
    points.push_back(
        (gravity.rotationFromYaw(yaw_true) * Eigen::Vector3d(0.9 * u(rng), 0.3 * u(rng), 0) +
         Eigen::Vector3d(0, 0, 0.75))
            .cast<float>());
  }
  OrientedBox box;
  ManhattanFrameEstimator::Result frame;
  ASSERT_TRUE(BoxEstimator().estimate(points, gravity, &box, &frame).ok());
  EXPECT_LT(yawErrorDeg(frame.yaw_rad, yaw_true), 1.0);
  EXPECT_NEAR(std::max(box.size_m.x(), box.size_m.y()), 0.9, 0.02);
  EXPECT_NEAR(std::min(box.size_m.x(), box.size_m.y()), 0.3, 0.02);
}

TEST(ManhattanBox, TableTopWithClutterTakesTheFootprintsYaw) {
  // A 2.0 x 0.9 m table top at 33° seen from above, with a 10 cm box (a cup, a chair back's edge)
  // on it at 0°: the clutter is the only source of horizontal normals, 2 % of them. Its peak stands
  // out, so Eq. 3 alone takes its yaw, and the box at that yaw needs twice the footprint the points
  // need: the elongated footprint's minimum-area rectangle gives the table's yaw instead (the real
  // redkitchen table was 31° off before).
  std::mt19937 rng(9);
  const GravityFrame gravity;
  const double yaw_true = 33.0 * kDeg;
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  PointCloud points;
  std::vector<Eigen::Vector3f> normals;
  const Eigen::Matrix3d R_table = gravity.rotationFromYaw(yaw_true);
  for (int i = 0; i < 10000; ++i) {
    points.push_back((R_table * Eigen::Vector3d(2.0 * u(rng), 0.9 * u(rng), 0.74)).cast<float>());
    normals.push_back(Eigen::Vector3f::UnitZ());
  }
  std::mt19937 rng_cube(10);
  const PointCloud cube = sampleBoxSurface(Eigen::Vector3d(0.1, 0.1, 0.1), 250, &rng_cube);
  for (const Eigen::Vector3f& p : cube) {
    // Its side faces (horizontal normals) only; the axis-aligned cube stands on the top.
    Eigen::Vector3f n = Eigen::Vector3f::Zero();
    if (std::abs(std::abs(p.x()) - 0.05f) < 1e-4f) n.x() = p.x() > 0 ? 1.f : -1.f;
    if (std::abs(std::abs(p.y()) - 0.05f) < 1e-4f) n.y() = p.y() > 0 ? 1.f : -1.f;
    if (n.isZero() || std::abs(n.sum()) != 1.f) continue;
    points.push_back(p + Eigen::Vector3f(0.3f, 0.1f, 0.79f));
    normals.push_back(n);
  }
  const size_t clutter = points.size() - 10000;
  ASSERT_GT(clutter, 100u);
  ASSERT_LT(clutter, 0.03 * points.size());

  OrientedBox box;
  ManhattanFrameEstimator::Result frame;
  ASSERT_TRUE(BoxEstimator().estimateFromNormals(points, normals, gravity, &box, &frame).ok());
  EXPECT_LT(yawErrorDeg(frame.yaw_rad, yaw_true), 1.0);
  EXPECT_NEAR(std::max(box.size_m.x(), box.size_m.y()), 2.0, 0.03);
  EXPECT_NEAR(std::min(box.size_m.x(), box.size_m.y()), 0.9, 0.03);

  BoxEstimator::Config paper;
  paper.footprint_yaw_area_ratio = 0.0;  // Eq. 3 whenever its peak stands out
  paper.outline_cell_m = 0.0;            // on the surface normals only
  ASSERT_TRUE(BoxEstimator(paper).estimateFromNormals(points, normals, gravity, &box, &frame).ok());
  EXPECT_LT(yawErrorDeg(frame.yaw_rad, 0.0), 1.0) << "the clutter's yaw";
  EXPECT_GT(yawErrorDeg(frame.yaw_rad, yaw_true), 25.0);
}

TEST(ManhattanBox, TableTopOutlineOutvotesAFewSkewedNormals) {
  // A 2.0 x 0.9 m table top seen from above: all its normals vertical, except those of a chair's
  // backrest beside it, 4 degrees off the table. Its footprint's minimum-area rectangle is not
  // clearly tighter at 4 degrees (area ratio 0.84), so only the top's outline can give the yaw.
  const GravityFrame gravity;
  const double yaw_true = 20.0 * kDeg;
  const Eigen::Matrix3d R_table = gravity.rotationFromYaw(yaw_true);
  PointCloud points;
  std::vector<Eigen::Vector3f> normals;
  for (double x = -1.0; x <= 1.0; x += 0.01) {
    for (double y = -0.45; y <= 0.45; y += 0.01) {
      points.push_back((R_table * Eigen::Vector3d(x, y, 0.74)).cast<float>());
      normals.push_back(Eigen::Vector3f::UnitZ());
    }
  }
  const Eigen::Matrix3d R_chair = gravity.rotationFromYaw(yaw_true + 4.0 * kDeg);
  for (int i = 0; i < 300; ++i) {
    points.push_back((R_chair * Eigen::Vector3d(-0.2 + 0.0015 * i, 0.46, 0.6)).cast<float>());
    normals.push_back(R_chair.col(1).cast<float>());
  }

  OrientedBox box;
  ManhattanFrameEstimator::Result frame;
  ASSERT_TRUE(BoxEstimator().estimateFromNormals(points, normals, gravity, &box, &frame).ok());
  EXPECT_LT(yawErrorDeg(frame.yaw_rad, yaw_true), 1.0);

  BoxEstimator::Config surface_only;
  surface_only.outline_cell_m = 0.0;
  ASSERT_TRUE(
      BoxEstimator(surface_only).estimateFromNormals(points, normals, gravity, &box, &frame).ok());
  EXPECT_GT(yawErrorDeg(frame.yaw_rad, yaw_true), 3.0) << "the scene does not test the outline";
}

TEST(ManhattanBox, CylinderGetsTightFootprint) {
  // Side normals of a cylinder are spread evenly over yaw: degenerate for Eq. 3. Any yaw fits a
  // circle, but the footprint of a half cylinder (seen from one side) is a 2r x r rectangle only
  // when aligned.
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double r = 0.2;
  const double yaw_true = -20.0 * kDeg;
  PointCloud points;
  for (int i = 0; i < 5000; ++i) {
    const double a = yaw_true + kDeg * 180.0 * u(rng);
    points.emplace_back(r * std::cos(a), r * std::sin(a), 0.5 * u(rng));
  }
  OrientedBox box;
  ASSERT_TRUE(BoxEstimator().estimate(points, GravityFrame(), &box).ok());
  EXPECT_LT(box.size_m.x() * box.size_m.y(), 2 * r * r * 1.05);
  EXPECT_NEAR(box.size_m.z(), 0.5, 0.01);
}

TEST(ManhattanBox, BadInputGivesErrors) {
  const BoxEstimator estimator;
  const GravityFrame gravity;
  OrientedBox box;
  EXPECT_FALSE(estimator.estimate({}, gravity, &box).ok());
  PointCloud few(5, Eigen::Vector3f(1, 2, 3));
  EXPECT_FALSE(estimator.estimate(few, gravity, &box).ok());
  PointCloud nans(50, Eigen::Vector3f(NAN, 0, 0));
  EXPECT_FALSE(estimator.estimate(nans, gravity, &box).ok());
  PointCloud ok_points;
  for (int i = 0; i < 12; ++i) ok_points.emplace_back(0.1f * i, 0.05f * (i % 3), 0.02f * (i % 4));
  EXPECT_FALSE(estimator.estimate(ok_points, gravity, nullptr).ok());
  BoxEstimator::Config bad;
  bad.manhattan.normal_radius_m = -1.0;
  EXPECT_FALSE(BoxEstimator(bad).estimate(ok_points, gravity, &box).ok());

  // A tiny cloud (all normals NaN) with a few NaN points mixed in still gets a box holding every
  // point.
  ok_points.emplace_back(NAN, 1.0f, 1.0f);
  ManhattanFrameEstimator::Result frame;
  ASSERT_TRUE(estimator.estimate(ok_points, gravity, &box, &frame).ok());
  ASSERT_TRUE(box.center_m.allFinite() && box.size_m.allFinite());
  for (int i = 0; i < 12; ++i) EXPECT_TRUE(box.contains(ok_points[i].cast<double>(), 1e-6));
  // Coincident points: a zero-size box, no crash.
  ASSERT_TRUE(estimator.estimate(PointCloud(20, Eigen::Vector3f(1, 1, 1)), gravity, &box).ok());
  EXPECT_LT(box.size_m.norm(), 1e-6);
  EXPECT_TRUE(box.center_m.isApprox(Eigen::Vector3d(1, 1, 1), 1e-6));
}

}  // namespace
}  // namespace mvod
