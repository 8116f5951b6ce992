// KeyframeSelector: every-n, motion and external modes on synthetic camera trajectories.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "multiview_object_detection/pipeline/stages/keyframe_selector.h"

namespace mvod {
namespace {


Eigen::Isometry3d poseAt(const Eigen::Vector3d& t, double yaw_deg) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() =
      Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = t;
  return T;
}

// Indices of the frames selected along a trajectory (30 Hz stamps).
std::vector<int> selectAlong(KeyframeSelector* selector,
                             const std::vector<Eigen::Isometry3d>& poses) {
  std::vector<int> selected;
  for (size_t i = 0; i < poses.size(); ++i) {
    if (selector->isKeyframe(poses[i], 100.0 + i / 30.0)) selected.push_back(static_cast<int>(i));
  }
  return selected;
}

}  // namespace

TEST(KeyframeSelectorTest, EveryNSelectsFirstAndEveryNth) {
  KeyframeSelector::Config config;
  config.mode = KeyframeSelector::Mode::kEveryN;
  config.every_n = 4;
  KeyframeSelector selector(config);
  std::vector<Eigen::Isometry3d> poses(13, Eigen::Isometry3d::Identity());
  EXPECT_EQ(selectAlong(&selector, poses), (std::vector<int>{0, 4, 8, 12}));
  EXPECT_EQ(selector.framesSeen(), 13);
  EXPECT_EQ(selector.keyframesSelected(), 4);
}

TEST(KeyframeSelectorTest, EveryNSkipsInvalidPosesWithoutCounting) {
  KeyframeSelector::Config config;
  config.mode = KeyframeSelector::Mode::kEveryN;
  config.every_n = 2;
  KeyframeSelector selector(config);
  Eigen::Isometry3d nan_pose = Eigen::Isometry3d::Identity();
  nan_pose.translation().x() = std::numeric_limits<double>::quiet_NaN();
  Eigen::Isometry3d sheared = Eigen::Isometry3d::Identity();
  sheared.linear()(0, 1) = 0.5;  // not a rotation
  EXPECT_FALSE(selector.isKeyframe(nan_pose, 1.0));
  EXPECT_FALSE(selector.isKeyframe(sheared, 1.1));
  EXPECT_EQ(selector.framesSeen(), 0);
  EXPECT_TRUE(selector.isKeyframe(Eigen::Isometry3d::Identity(), 1.2));
  EXPECT_FALSE(selector.isKeyframe(nan_pose, 1.3));
  EXPECT_FALSE(selector.isKeyframe(Eigen::Isometry3d::Identity(), 1.4));
  EXPECT_TRUE(selector.isKeyframe(Eigen::Isometry3d::Identity(), 1.5));
}

TEST(KeyframeSelectorTest, MotionSelectsOnTranslation) {
  KeyframeSelector::Config config;
  config.mode = KeyframeSelector::Mode::kMotion;
  config.min_translation_m = 0.2;
  config.min_rotation_deg = 90.0;
  KeyframeSelector selector(config);
  // 5 cm per frame along x: a keyframe every 4 frames (0.2 m), measured from the last keyframe.
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < 13; ++i) poses.push_back(poseAt(Eigen::Vector3d(0.05 * i, 0, 0), 0.0));
  EXPECT_EQ(selectAlong(&selector, poses), (std::vector<int>{0, 4, 8, 12}));
  EXPECT_TRUE(selector.lastKeyframePose().translation().isApprox(Eigen::Vector3d(0.6, 0, 0)));
}

TEST(KeyframeSelectorTest, MotionSelectsOnRotationAlone) {
  KeyframeSelector::Config config;
  config.mode = KeyframeSelector::Mode::kMotion;
  config.min_translation_m = 10.0;
  config.min_rotation_deg = 15.0;
  KeyframeSelector selector(config);
  // 4 degrees per frame in place: 15 deg is reached at frame 4 (16 deg), then 8 and 12.
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < 13; ++i) poses.push_back(poseAt(Eigen::Vector3d(1, 2, 3), 4.0 * i));
  EXPECT_EQ(selectAlong(&selector, poses), (std::vector<int>{0, 4, 8, 12}));
}

TEST(KeyframeSelectorTest, MotionStandingStillGivesOneKeyframe) {
  KeyframeSelector selector;  // defaults: motion, 0.2 m, 15 deg
  std::vector<Eigen::Isometry3d> poses(50, poseAt(Eigen::Vector3d(1, 0, 0), 30.0));
  EXPECT_EQ(selectAlong(&selector, poses), (std::vector<int>{0}));
}

TEST(KeyframeSelectorTest, MotionBetweenMeasuresAngleAndDistance) {
  double translation_m = 0.0;
  double rotation_deg = 0.0;
  KeyframeSelector::motionBetween(poseAt(Eigen::Vector3d(0, 0, 0), 10.0),
                                  poseAt(Eigen::Vector3d(3, 4, 0), 100.0), &translation_m,
                                  &rotation_deg);
  EXPECT_NEAR(translation_m, 5.0, 1e-12);
  EXPECT_NEAR(rotation_deg, 90.0, 1e-9);
  KeyframeSelector::motionBetween(poseAt(Eigen::Vector3d::Zero(), 0.0),
                                  poseAt(Eigen::Vector3d::Zero(), 180.0), &translation_m,
                                  &rotation_deg);
  EXPECT_NEAR(rotation_deg, 180.0, 1e-6);
}

TEST(KeyframeSelectorTest, ExternalMatchesStampsWithinTolerance) {
  KeyframeSelector::Config config;
  config.mode = KeyframeSelector::Mode::kExternal;
  config.external_stamp_tolerance_s = 0.005;
  KeyframeSelector selector(config);
  const Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  selector.addExternalKeyframe(1.002);  // matches the frame at 1.0
  selector.addExternalKeyframe(1.5);    // matches nothing (no frame there)
  selector.addExternalKeyframe(2.0);
  EXPECT_FALSE(selector.canDecide(2.2));
  EXPECT_TRUE(selector.canDecide(1.9));
  EXPECT_TRUE(selector.isKeyframe(T, 1.0));
  EXPECT_FALSE(selector.isKeyframe(T, 1.1));
  EXPECT_FALSE(selector.isKeyframe(T, 1.6));  // 1.5 is passed and dropped
  EXPECT_TRUE(selector.isKeyframe(T, 2.0));
  EXPECT_FALSE(selector.isKeyframe(T, 2.0 + 1.0 / 30.0));  // each stamp is used once
  // Stamps older than the last decided frame are ignored.
  selector.addExternalKeyframe(1.0);
  EXPECT_FALSE(selector.isKeyframe(T, 2.1));
  EXPECT_EQ(selector.keyframesSelected(), 2);
}

TEST(KeyframeSelectorTest, ExternalOutOfOrderStampsAreSorted) {
  KeyframeSelector::Config config;
  config.mode = KeyframeSelector::Mode::kExternal;
  KeyframeSelector selector(config);
  selector.addExternalKeyframe(3.0);
  selector.addExternalKeyframe(1.0);
  EXPECT_TRUE(selector.isKeyframe(Eigen::Isometry3d::Identity(), 1.0));
  EXPECT_FALSE(selector.isKeyframe(Eigen::Isometry3d::Identity(), 2.0));
  EXPECT_TRUE(selector.isKeyframe(Eigen::Isometry3d::Identity(), 3.0));
}

TEST(KeyframeSelectorTest, ResetForgetsTheLastKeyframe) {
  KeyframeSelector selector;
  EXPECT_TRUE(selector.isKeyframe(Eigen::Isometry3d::Identity(), 1.0));
  EXPECT_FALSE(selector.isKeyframe(Eigen::Isometry3d::Identity(), 1.1));
  selector.reset();
  EXPECT_FALSE(selector.hasKeyframe());
  EXPECT_EQ(selector.keyframesSelected(), 0);
  EXPECT_TRUE(selector.isKeyframe(Eigen::Isometry3d::Identity(), 0.5));
}

TEST(KeyframeSelectorTest, SetConfigKeepsStateAndAppliesNewThresholds) {
  KeyframeSelector selector;  // 0.2 m
  EXPECT_TRUE(selector.isKeyframe(poseAt(Eigen::Vector3d::Zero(), 0), 1.0));
  EXPECT_FALSE(selector.isKeyframe(poseAt(Eigen::Vector3d(0.1, 0, 0), 0), 1.1));
  KeyframeSelector::Config config = selector.config();
  config.min_translation_m = 0.05;
  selector.setConfig(config);
  EXPECT_TRUE(selector.isKeyframe(poseAt(Eigen::Vector3d(0.1, 0, 0), 0), 1.2));
  EXPECT_EQ(selector.keyframesSelected(), 2);
}

TEST(KeyframeSelectorTest, ConfigValidationAndModeNames) {
  KeyframeSelector::Config config;
  EXPECT_TRUE(config.isValid().ok());
  config.every_n = 0;
  EXPECT_FALSE(config.isValid().ok());
  EXPECT_NE(config.isValid().message().find("every_n"), std::string::npos);
  config = KeyframeSelector::Config();
  config.min_translation_m = -1.0;
  EXPECT_FALSE(config.isValid().ok());
  config = KeyframeSelector::Config();
  config.min_rotation_deg = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(config.isValid().ok());

  KeyframeSelector::Mode mode = KeyframeSelector::Mode::kMotion;
  EXPECT_TRUE(KeyframeSelector::modeFromString("topic", &mode).ok());
  EXPECT_EQ(mode, KeyframeSelector::Mode::kExternal);
  EXPECT_TRUE(KeyframeSelector::modeFromString("every_n", &mode).ok());
  EXPECT_EQ(mode, KeyframeSelector::Mode::kEveryN);
  const Status bad = KeyframeSelector::modeFromString("sometimes", &mode);
  EXPECT_FALSE(bad.ok());
  EXPECT_NE(bad.message().find("sometimes"), std::string::npos);
  EXPECT_EQ(mode, KeyframeSelector::Mode::kEveryN);  // untouched on error
}

}  // namespace mvod
