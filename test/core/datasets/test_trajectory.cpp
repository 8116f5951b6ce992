// A SLAM's trajectory as the poses of a dataset's frames (trajectory.h; offline_detection and
// dataset_to_bag --trajectory, --keyframes): the TUM format read and checked, frames matched by
// stamp, the SLAM's world aligned at the first frame, the colour camera's pose turned into the
// depth camera's.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "multiview_object_detection/datasets/trajectory.h"
#include "test_files.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

Eigen::Isometry3d pose(double yaw_rad, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T.translation() = t;
  return T;
}

std::string tumLine(double stamp_s, const Eigen::Isometry3d& T) {
  const Eigen::Quaterniond q(T.linear());
  char line[200];
  std::snprintf(line, sizeof(line), "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", stamp_s,
                T.translation().x(), T.translation().y(), T.translation().z(), q.x(), q.y(), q.z(),
                q.w());
  return line;
}

class TrajectoryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::freshTestDir("mvod_trajectory");
    T_C_D_.translation() = Eigen::Vector3d(-0.0225, -0.0025, 0.0);
    // Frames 0, 5, 10, 15 at index / 30 s; the dataset's own depth camera poses.
    source_.directory = dir_.string();
    source_.indices = {0, 5, 10, 15};
    source_.stamp_s = [](int index) { return index / 30.0; };
    source_.has_gravity = true;
    const Eigen::Isometry3d T_C_D = T_C_D_;
    source_.load = [T_C_D](int index, RgbdFrame* frame) {
      frame->name = "frame-" + std::to_string(index);
      frame->stamp_s = index / 30.0;
      frame->T_C_D = T_C_D;
      frame->T_W_D = pose(0.5, Eigen::Vector3d(1.0, 2.0, 3.0)) *
                     pose(0.01 * index, Eigen::Vector3d(0.1 * index, 0, 0));
      return Status::Ok();
    };
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name) << text;
    return (dir_ / name).string();
  }

  fs::path dir_;
  DatasetSource source_;
  Eigen::Isometry3d T_C_D_ = Eigen::Isometry3d::Identity();
};

// The SLAM's colour-camera poses of frames 5, 10 and 15 (frame 0 untracked), in its own world.
TEST_F(TrajectoryTest, FramesTakeTheSlamsPosesInTheDatasetsWorld) {
  const auto slam = [](int index) {
    return pose(0.02 * index, Eigen::Vector3d(0.05 * index, 0.1, 0));
  };
  const std::string file =
      write("CameraTrajectory.txt", "# t tx ty tz qx qy qz qw\n" + tumLine(15 / 30.0, slam(15)) +
                                        tumLine(5 / 30.0 + 0.004, slam(5)) +
                                        tumLine(10 / 30.0, slam(10)));
  TrajectoryOptions options;
  options.trajectory = file;
  RgbdFrame first_own;
  ASSERT_TRUE(source_.load(5, &first_own).ok());
  ASSERT_TRUE(applyTrajectory(options, &source_).ok());
  EXPECT_EQ(source_.indices, (std::vector<int>{5, 10, 15})) << "frame 0 has no pose";
  EXPECT_TRUE(source_.has_gravity) << "aligned: the dataset's gravity holds";
  RgbdFrame first;
  RgbdFrame last;
  ASSERT_TRUE(source_.load(5, &first).ok());
  ASSERT_TRUE(source_.load(15, &last).ok());
  // Aligned at the first frame: its pose is the dataset's.
  EXPECT_TRUE(first.T_W_D.isApprox(first_own.T_W_D, 1e-6));
  // Later frames move as the SLAM says, the depth camera T_C_D from the colour camera.
  const Eigen::Isometry3d slam_motion = (slam(5) * T_C_D_).inverse() * (slam(15) * T_C_D_);
  EXPECT_TRUE((first.T_W_D.inverse() * last.T_W_D).isApprox(slam_motion, 1e-6));

  // The SLAM's world as it is: gravity unknown.
  source_.indices = {0, 5, 10, 15};
  options.align_first_frame = false;
  DatasetSource slam_world = source_;
  slam_world.load = [this](int index, RgbdFrame* frame) {
    frame->name = "frame-" + std::to_string(index);
    frame->T_C_D = T_C_D_;
    return Status::Ok();
  };
  ASSERT_TRUE(applyTrajectory(options, &slam_world).ok());
  EXPECT_FALSE(slam_world.has_gravity);
  RgbdFrame in_slam_world;
  ASSERT_TRUE(slam_world.load(10, &in_slam_world).ok());
  EXPECT_TRUE(in_slam_world.T_W_D.isApprox(slam(10) * T_C_D_, 1e-6));
}

TEST_F(TrajectoryTest, KeyframesKeepTheirFramesOnlyWithTheirPoses) {
  const Eigen::Isometry3d kf = pose(0.3, Eigen::Vector3d(0.4, 0, 0));
  const std::string all = write("all.txt", tumLine(0.0, Eigen::Isometry3d::Identity()) +
                                               tumLine(5 / 30.0, pose(0.1, {0.2, 0, 0})) +
                                               tumLine(10 / 30.0, pose(0.2, {0.3, 0, 0})));
  const std::string keyframes =
      write("kf.txt", tumLine(0.0, Eigen::Isometry3d::Identity()) + tumLine(10 / 30.0, kf));
  TrajectoryOptions options;
  options.trajectory = all;
  options.keyframes = keyframes;
  options.align_first_frame = false;
  ASSERT_TRUE(applyTrajectory(options, &source_).ok());
  EXPECT_EQ(source_.indices, (std::vector<int>{0, 10}));
  RgbdFrame frame;
  ASSERT_TRUE(source_.load(10, &frame).ok());
  EXPECT_TRUE(frame.T_W_D.isApprox(kf * T_C_D_, 1e-6)) << "not the keyframe file's pose";
}

TEST_F(TrajectoryTest, BadFilesAreErrorsNamingFileAndLine) {
  const auto refused = [&](const std::string& text, const std::string& needle) {
    TrajectoryOptions options;
    options.trajectory = write("bad.txt", text);
    DatasetSource copy = source_;
    const Status status = applyTrajectory(options, &copy);
    EXPECT_FALSE(status.ok()) << text;
    EXPECT_NE(status.message().find(needle), std::string::npos) << status.message();
    EXPECT_EQ(copy.indices, source_.indices) << "changed on failure";
  };
  refused("0.0 1 2 3 0 0 0\n", "bad.txt:1: expected 8 finite numbers");
  refused("# ok\n0.0 1 2 3 0 0 0 1 9\n", "bad.txt:2");
  refused("0.0 1 nan 3 0 0 0 1\n", "bad.txt:1");
  refused("0.0 1 2 3 0 0 0 2\n", "norm");
  refused("# nothing\n", "no poses");
  refused("100.0 1 2 3 0 0 0 1\n", "no pose within");
  TrajectoryOptions missing;
  missing.trajectory = (dir_ / "absent.txt").string();
  EXPECT_FALSE(applyTrajectory(missing, &source_).ok());
}

}  // namespace
}  // namespace mvod
