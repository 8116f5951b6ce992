// GravityEstimator: gravity from the floor of a ray-cast room, in a world frame that is not
// gravity-aligned (like ORB-SLAM2's first-camera map frame).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "multiview_object_detection/pipeline/stages/gravity_estimator.h"

namespace mvod {
namespace {

double degToRad(double deg) { return deg * kPi / 180.0; }

double angleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::max(-1.0, std::min(1.0, a.normalized().dot(b.normalized())))) * 180.0 / kPi;
}

// Room in a gravity-aligned frame G (z up): floor z = 0 (optional), a wall at y = wall_y_m.
struct GravityTestRoom {
  bool with_floor = true;
  double wall_y_m = 3.0;

  double cast(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const {
    double best = std::numeric_limits<double>::infinity();
    if (with_floor && d.z() < -1e-9) best = std::min(best, -o.z() / d.z());
    if (d.y() > 1e-9) best = std::min(best, (wall_y_m - o.y()) / d.y());
    return best;
  }
};

// Optical frame (x right, y down, z forward) at `position` in G, looking along +y, pitched down by
// pitch_deg and rolled by roll_deg about the viewing axis.
Eigen::Isometry3d gravityTestCamera(const Eigen::Vector3d& position, double pitch_deg,
                                    double roll_deg) {
  const double p = degToRad(pitch_deg);
  Eigen::Matrix3d R;
  R.col(0) = Eigen::Vector3d(1, 0, 0);
  R.col(1) = Eigen::Vector3d(0, -std::sin(p), -std::cos(p));
  R.col(2) = Eigen::Vector3d(0, std::cos(p), -std::sin(p));
  Eigen::Isometry3d T_G_D = Eigen::Isometry3d::Identity();
  T_G_D.linear() = R * Eigen::AngleAxisd(degToRad(roll_deg), Eigen::Vector3d::UnitZ());
  T_G_D.translation() = position;
  return T_G_D;
}

// A whole depth frame (every 4th pixel of 640 x 480, as ObjectMapper::updateGravity takes it), in
// the depth-camera frame, with depth noise.
PointCloud renderDepthCloud(const GravityTestRoom& room, const Eigen::Isometry3d& T_G_D) {
  const double fx = 525.0, fy = 525.0, cx = 319.5, cy = 239.5;
  std::mt19937 rng(11);
  std::normal_distribution<double> unit_noise(0.0, 1.0);
  PointCloud points_D;
  for (int v = 0; v < 480; v += 4) {
    for (int u = 0; u < 640; u += 4) {
      const Eigen::Vector3d ray_D((u - cx) / fx, (v - cy) / fy, 1.0);
      const double depth = room.cast(T_G_D.translation(), T_G_D.linear() * ray_D);
      if (!(depth > 0.4 && depth < 5.0)) continue;
      const double sigma_m = 0.0012 + 0.0019 * (depth - 0.4) * (depth - 0.4);
      points_D.push_back(((depth + sigma_m * unit_noise(rng)) * ray_D).cast<float>());
    }
  }
  return points_D;
}

// The map frame W is the first camera's frame: W = a camera pose C0 in G, so T_W_G = T_G_C0^-1.
Eigen::Isometry3d mapFromGravityFrame() {
  return gravityTestCamera(Eigen::Vector3d(-0.5, -0.8, 1.4), 12.0, -7.0).inverse();
}

}  // namespace

TEST(GravityEstimatorRoom, FloorGivesGravityInTiltedMapFrame) {
  const GravityTestRoom room;
  const Eigen::Isometry3d T_W_G = mapFromGravityFrame();
  const Eigen::Isometry3d T_G_D = gravityTestCamera(Eigen::Vector3d(0.4, 0.2, 1.3), 28.0, 6.0);
  const Eigen::Isometry3d T_W_D = T_W_G * T_G_D;
  const Eigen::Vector3d true_down_W = T_W_G.linear() * Eigen::Vector3d(0, 0, -1);
  // The premise: W's own -z is far from gravity, so an estimator that ignored the data would fail.
  ASSERT_GT(angleDeg(true_down_W, Eigen::Vector3d(0, 0, -1)), 45.0);

  GravityEstimator estimator;
  EXPECT_FALSE(estimator.hasEstimate());
  EXPECT_TRUE(estimator.addFrame(renderDepthCloud(room, T_G_D), T_W_D));
  ASSERT_TRUE(estimator.hasEstimate());
  EXPECT_LT(angleDeg(estimator.gravityDown_W(), true_down_W), 2.0);
  EXPECT_NEAR(estimator.gravityDown_W().norm(), 1.0, 1e-6);
  EXPECT_GT(estimator.supportingPoints(), 0);
}

TEST(GravityEstimatorRoom, DeterministicAndKeepsBestSupportedFrame) {
  const GravityTestRoom room;
  const Eigen::Isometry3d T_W_G = mapFromGravityFrame();
  const Eigen::Vector3d true_down_W = T_W_G.linear() * Eigen::Vector3d(0, 0, -1);
  const Eigen::Isometry3d T_G_D1 = gravityTestCamera(Eigen::Vector3d(0.0, 0.0, 1.2), 20.0, -4.0);
  const Eigen::Isometry3d T_G_D2 = gravityTestCamera(Eigen::Vector3d(0.3, 0.5, 1.1), 30.0, 3.0);
  const PointCloud frame1 = renderDepthCloud(room, T_G_D1);
  const PointCloud frame2 = renderDepthCloud(room, T_G_D2);

  GravityEstimator a, b;
  ASSERT_TRUE(a.addFrame(frame1, T_W_G * T_G_D1));
  ASSERT_TRUE(b.addFrame(frame1, T_W_G * T_G_D1));
  EXPECT_EQ(a.gravityDown_W(), b.gravityDown_W());
  EXPECT_EQ(a.supportingPoints(), b.supportingPoints());

  const int support_after_one = a.supportingPoints();
  ASSERT_TRUE(a.addFrame(frame2, T_W_G * T_G_D2));
  EXPECT_GE(a.supportingPoints(), support_after_one);
  EXPECT_LT(angleDeg(a.gravityDown_W(), true_down_W), 2.0);
}

TEST(GravityEstimatorRoom, WallOnlyGivesNoEstimate) {
  GravityTestRoom room;
  room.with_floor = false;
  room.wall_y_m = 2.0;
  const Eigen::Isometry3d T_G_D = gravityTestCamera(Eigen::Vector3d(0.0, 0.0, 1.3), 15.0, 0.0);
  const PointCloud points_D = renderDepthCloud(room, T_G_D);
  ASSERT_GT(points_D.size(), 1000u);  // the camera does see the wall
  GravityEstimator estimator;
  EXPECT_FALSE(estimator.addFrame(points_D, mapFromGravityFrame() * T_G_D));
  EXPECT_FALSE(estimator.hasEstimate());
  EXPECT_EQ(estimator.supportingPoints(), 0);
}

TEST(GravityEstimatorRoom, FloorBeyondTiltLimitGivesNoEstimate) {
  // Looking 45 degrees down, the floor's normal is outside the 35 degree cone around camera-up; a
  // slanted cut through the floor inside the cone must not pass for a horizontal plane.
  const GravityTestRoom room;
  GravityEstimator estimator;
  for (const double roll_deg : {-10.0, 0.0, 10.0}) {
    const Eigen::Isometry3d T_G_D =
        gravityTestCamera(Eigen::Vector3d(0.0, 0.0, 1.3), 45.0, roll_deg);
    EXPECT_FALSE(estimator.addFrame(renderDepthCloud(room, T_G_D), mapFromGravityFrame() * T_G_D));
  }
  // A wider cone takes the same floor, with the right answer.
  GravityEstimator::Config config;
  config.max_tilt_from_camera_up_deg = 55.0;
  GravityEstimator wide(config);
  const Eigen::Isometry3d T_G_D = gravityTestCamera(Eigen::Vector3d(0.0, 0.0, 1.3), 45.0, -10.0);
  ASSERT_TRUE(wide.addFrame(renderDepthCloud(room, T_G_D), mapFromGravityFrame() * T_G_D));
  const Eigen::Vector3d true_down_W = mapFromGravityFrame().linear() * Eigen::Vector3d(0, 0, -1);
  EXPECT_LT(angleDeg(wide.gravityDown_W(), true_down_W), 2.0);
}

TEST(GravityEstimatorBadInput, EmptyNonFiniteAndBadPose) {
  GravityEstimator estimator;
  EXPECT_FALSE(estimator.addFrame(PointCloud(), Eigen::Isometry3d::Identity()));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_FALSE(estimator.addFrame(PointCloud(500, Eigen::Vector3f(nan, 0.0f, 1.0f)),
                                  Eigen::Isometry3d::Identity()));
  // A good floor with a broken pose is ignored.
  const GravityTestRoom room;
  const Eigen::Isometry3d T_G_D = gravityTestCamera(Eigen::Vector3d(0.0, 0.0, 1.2), 25.0, 0.0);
  Eigen::Isometry3d bad_pose = T_G_D;
  bad_pose.linear() *= 2.0;
  EXPECT_FALSE(estimator.addFrame(renderDepthCloud(room, T_G_D), bad_pose));
  EXPECT_FALSE(estimator.hasEstimate());
}

TEST(GravityEstimatorConfig, Validation) {
  GravityEstimator::Config config;
  EXPECT_TRUE(config.isValid().ok());
  EXPECT_NE(config.print().find("ransac_iterations: 300"), std::string::npos);
  GravityEstimator::Config bad = config;
  bad.plane_distance_threshold_m = 0.0;
  EXPECT_FALSE(bad.isValid().ok());
  bad = config;
  bad.ransac_iterations = 0;
  EXPECT_FALSE(bad.isValid().ok());
  bad = config;
  bad.max_tilt_from_camera_up_deg = 95.0;
  EXPECT_FALSE(bad.isValid().ok());
  bad = config;
  bad.min_plane_fraction = 1.5;
  EXPECT_FALSE(bad.isValid().ok());
  bad = config;
  bad.voxel_size_m = -0.05;
  EXPECT_FALSE(bad.isValid().ok());
}

}  // namespace mvod
