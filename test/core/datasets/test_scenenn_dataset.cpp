// SceneNNDataset on a tiny SceneNN-layout folder written by the test (3 frames): round trip of
// images, poses (1-based files <-> 0-based trajectory blocks), time stamps and intrinsics, the
// defaults, and bad files (the message must name the file). registerDepthToColor on known
// geometry.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "multiview_object_detection/datasets/scenenn_dataset.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

Eigen::Isometry3d sceneNNTestPose(int block) {
  return Eigen::Translation3d(0.2 * block, 0.5, -1.0 + 0.1 * block) *
         Eigen::AngleAxisd(0.2 + 0.1 * block, Eigen::Vector3d(0.1, 1.0, -0.3).normalized());
}

cv::Mat sceneNNTestDepth(int frame) {
  cv::Mat depth(6, 8, CV_16UC1);
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) depth.at<uint16_t>(v, u) = 900 + 100 * frame + 10 * v + u;
  }
  depth.at<uint16_t>(2, 3) = 0;  // a hole
  return depth;
}

cv::Mat sceneNNTestColour(int frame) {
  cv::Mat colour(6, 8, CV_8UC3);
  for (int v = 0; v < colour.rows; ++v) {
    for (int u = 0; u < colour.cols; ++u) {
      colour.at<cv::Vec3b>(v, u) = cv::Vec3b(u * 30, v * 40, frame * 50);
    }
  }
  return colour;
}

void writeSceneNNText(const fs::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

std::string trajectoryBlock(int header_index, const Eigen::Isometry3d& T) {
  std::string text = std::to_string(header_index) + " " + std::to_string(header_index) + " " +
                     std::to_string(header_index + 1) + "\n";
  char buffer[64];
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      std::snprintf(buffer, sizeof(buffer), "%.12f%s", T.matrix()(r, c), c < 3 ? " " : "\n");
      text += buffer;
    }
  }
  return text;
}

class SceneNNDatasetTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("mvod_scenenn_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "image");
    fs::create_directories(dir_ / "depth");
    for (int k = 1; k <= 3; ++k) {
      char name[32];
      std::snprintf(name, sizeof(name), "%05d.png", k);
      ASSERT_TRUE(cv::imwrite((dir_ / "image" / ("image" + std::string(name))).string(),
                              sceneNNTestColour(k)));
      ASSERT_TRUE(cv::imwrite((dir_ / "depth" / ("depth" + std::string(name))).string(),
                              sceneNNTestDepth(k)));
    }
    // Blocks out of order and a blank line: the header index, not the position, names the frame.
    writeSceneNNText(dir_ / "trajectory.log", trajectoryBlock(2, sceneNNTestPose(2)) + "\n" +
                                                  trajectoryBlock(0, sceneNNTestPose(0)) +
                                                  trajectoryBlock(1, sceneNNTestPose(1)));
    writeSceneNNText(dir_ / "timestamp.txt",
                     "1 1000000 1000500\n2 1033333 1033800\n3 1066667 1066000\n");
    writeSceneNNText(dir_ / "asus.ini",
                     "[camera]\n# Asus Xtion\nfx 500.5\nfy = 501.25\ncx=3.5 ; centre\ncy 2.5\n"
                     "depth_width 640\n");
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path dir_;
};

TEST_F(SceneNNDatasetTest, OpensAndLoadsEveryFrame) {
  SceneNNDataset dataset;
  const Status status = SceneNNDataset::open(dir_.string(), &dataset);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(dataset.size(), 3u);
  EXPECT_EQ(dataset.frameIndices(), (std::vector<int>{1, 2, 3}));
  EXPECT_TRUE(dataset.hasTimestamps());
  EXPECT_DOUBLE_EQ(dataset.intrinsics().fx, 500.5);
  EXPECT_DOUBLE_EQ(dataset.intrinsics().fy, 501.25);
  EXPECT_DOUBLE_EQ(dataset.intrinsics().cx, 3.5);
  EXPECT_DOUBLE_EQ(dataset.intrinsics().cy, 2.5);
  EXPECT_EQ(dataset.intrinsicsPath(), (dir_ / "asus.ini").string());

  const double expected_stamps_s[] = {1.0, 1.033333, 1.066667};
  for (int k = 1; k <= 3; ++k) {
    RgbdFrame frame;
    const Status load = dataset.load(k, &frame);
    ASSERT_TRUE(load.ok()) << load.message();
    EXPECT_EQ(frame.index, k);
    EXPECT_EQ(frame.name, SceneNNDataset::frameName(k));
    EXPECT_NEAR(frame.stamp_s, expected_stamps_s[k - 1], 1e-9);
    // image0000k.png <-> trajectory block with header k - 1.
    EXPECT_TRUE(frame.T_W_D.isApprox(sceneNNTestPose(k - 1), 1e-9)) << "frame " << k;
    EXPECT_FALSE(frame.T_W_D.isApprox(sceneNNTestPose(k % 3), 1e-3));
    EXPECT_EQ(cv::norm(frame.depth, sceneNNTestDepth(k), cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(frame.color_bgr, sceneNNTestColour(k), cv::NORM_INF), 0.0);
    EXPECT_TRUE(frame.registered);
    EXPECT_EQ(frame.K_depth.width, 8);
    EXPECT_EQ(frame.K_depth.height, 6);
    EXPECT_DOUBLE_EQ(frame.K_color.fx, 500.5);
    EXPECT_TRUE(frame.validate().ok());
  }
  EXPECT_EQ(SceneNNDataset::frameName(12), "image00012");
}

TEST_F(SceneNNDatasetTest, DefaultsWithoutAsusIniOrTimestamps) {
  fs::remove(dir_ / "asus.ini");
  fs::remove(dir_ / "timestamp.txt");
  SceneNNDataset dataset;
  const Status status = SceneNNDataset::open(dir_.string(), &dataset);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_DOUBLE_EQ(dataset.intrinsics().fx, SceneNNDataset::kDefaultFocalPx);
  EXPECT_DOUBLE_EQ(dataset.intrinsics().fy, 544.47329);
  EXPECT_DOUBLE_EQ(dataset.intrinsics().cx, 320.0);
  EXPECT_DOUBLE_EQ(dataset.intrinsics().cy, 240.0);
  EXPECT_TRUE(dataset.intrinsicsPath().empty());
  EXPECT_FALSE(dataset.hasTimestamps());
  RgbdFrame frame;
  ASSERT_TRUE(dataset.load(3, &frame).ok());
  EXPECT_NEAR(frame.stamp_s, 2.0 / 30.0, 1e-12);

  // The main repo's shared intrinsic/asus.ini, with absent keys left at their defaults.
  fs::create_directories(dir_ / "intrinsic");
  writeSceneNNText(dir_ / "intrinsic" / "asus.ini", "fx 600\n");
  ASSERT_TRUE(SceneNNDataset::open(dir_.string(), &dataset).ok());
  EXPECT_DOUBLE_EQ(dataset.intrinsics().fx, 600.0);
  EXPECT_DOUBLE_EQ(dataset.intrinsics().fy, 544.47329);
  EXPECT_DOUBLE_EQ(dataset.intrinsics().cx, 320.0);
}

// Expects open() to fail with a message containing `needle`.
void expectOpenFails(const fs::path& dir, const std::string& needle) {
  SceneNNDataset dataset;
  const Status status = SceneNNDataset::open(dir.string(), &dataset);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find(needle), std::string::npos) << status.message();
}

TEST_F(SceneNNDatasetTest, BadFilesAreErrorsNamingTheFile) {
  expectOpenFails(dir_ / "missing", "does not exist");

  writeSceneNNText(dir_ / "asus.ini", "fx abc\n");
  expectOpenFails(dir_, "asus.ini:1");
  writeSceneNNText(dir_ / "asus.ini", "fx -3\n");
  expectOpenFails(dir_, "asus.ini");
  fs::remove(dir_ / "asus.ini");

  writeSceneNNText(dir_ / "timestamp.txt", "1 1000000 1000500\n2 abc 5\n3 1 1\n");
  expectOpenFails(dir_, "timestamp.txt:2");
  // Frame 3 without a stamp, then without a pose (only two blocks): open() succeeds (frames 1-2
  // are usable), checkFrame() and load() of frame 3 fail naming the file.
  writeSceneNNText(dir_ / "timestamp.txt", "1 1000000 1000500\n2 1 1\n");
  {
    SceneNNDataset dataset;
    ASSERT_TRUE(SceneNNDataset::open(dir_.string(), &dataset).ok());
    EXPECT_TRUE(dataset.checkFrame(2).ok());
    const Status check = dataset.checkFrame(3);
    EXPECT_FALSE(check.ok());
    EXPECT_NE(check.message().find("timestamp.txt: no time stamp for frame 3"), std::string::npos)
        << check.message();
    RgbdFrame frame;
    EXPECT_FALSE(dataset.load(3, &frame).ok());
  }
  fs::remove(dir_ / "timestamp.txt");
  writeSceneNNText(dir_ / "trajectory.log",
                   trajectoryBlock(0, sceneNNTestPose(0)) + trajectoryBlock(1, sceneNNTestPose(1)));
  {
    SceneNNDataset dataset;
    ASSERT_TRUE(SceneNNDataset::open(dir_.string(), &dataset).ok());
    RgbdFrame frame;
    EXPECT_TRUE(dataset.load(2, &frame).ok());
    const Status load = dataset.load(3, &frame);
    EXPECT_FALSE(load.ok());
    EXPECT_NE(load.message().find("trajectory.log: no pose for frame 3"), std::string::npos)
        << load.message();
    EXPECT_NE(load.message().find("header index 2"), std::string::npos) << load.message();
    EXPECT_FALSE(dataset.checkFrame(0).ok());
  }
  // A truncated block, a bad number, a non-rigid matrix, a duplicate.
  std::string text =
      trajectoryBlock(0, sceneNNTestPose(0)) + trajectoryBlock(1, sceneNNTestPose(1));
  writeSceneNNText(dir_ / "trajectory.log", text + "2 2 3\n1 0 0 0\n0 1 0 0\n");
  expectOpenFails(dir_, "trajectory.log");
  writeSceneNNText(dir_ / "trajectory.log", text + "2 2 3\n1 0 0 0\n0 1 x 0\n0 0 1 0\n0 0 0 1\n");
  expectOpenFails(dir_, "trajectory.log:");
  writeSceneNNText(dir_ / "trajectory.log", text + "2 2 3\n2 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  expectOpenFails(dir_, "not a rigid transform");
  writeSceneNNText(dir_ / "trajectory.log", text + trajectoryBlock(1, sceneNNTestPose(1)));
  expectOpenFails(dir_, "appears twice");
  fs::remove(dir_ / "trajectory.log");
  expectOpenFails(dir_, "trajectory.log: no such file");
  writeSceneNNText(dir_ / "trajectory.log", text + trajectoryBlock(2, sceneNNTestPose(2)));

  // Images: a missing colour image and an 8-bit depth image fail in load(), naming the file.
  SceneNNDataset dataset;
  ASSERT_TRUE(SceneNNDataset::open(dir_.string(), &dataset).ok());
  fs::remove(dir_ / "image" / "image00002.png");
  RgbdFrame frame;
  Status status = dataset.load(2, &frame);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("image00002.png"), std::string::npos) << status.message();
  ASSERT_TRUE(cv::imwrite((dir_ / "depth" / "depth00003.png").string(), sceneNNTestColour(3)));
  status = dataset.load(3, &frame);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("depth00003.png"), std::string::npos) << status.message();

  fs::remove_all(dir_ / "depth");
  expectOpenFails(dir_, "depth");
}

TEST(RegisterDepthToColorTest, MovesDepthIntoTheColourCamera) {
  // A fronto-parallel plane at 2 m seen by a depth camera; the colour camera is 0.1 m to its right
  // (x), with another focal length and image size.
  CameraIntrinsics K_depth{50.0, 50.0, 15.5, 11.5, 32, 24};
  CameraIntrinsics K_color{80.0, 80.0, 24.0, 18.0, 48, 36};
  cv::Mat depth_D(24, 32, CV_16UC1, cv::Scalar(2000));
  depth_D.at<uint16_t>(5, 5) = 0;
  Eigen::Isometry3d T_C_D = Eigen::Isometry3d::Identity();
  T_C_D.translation() = Eigen::Vector3d(-0.1, 0.0, 0.0);  // depth camera at x = -0.1 in C

  cv::Mat depth_C;
  Status status = registerDepthToColor(depth_D, K_depth, K_color, T_C_D, &depth_C);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(depth_C.type(), CV_16UC1);
  ASSERT_EQ(depth_C.cols, 48);
  ASSERT_EQ(depth_C.rows, 36);
  // Depth columns u_D = 0..31 see x_D = (u_D - 15.5) * 2 / 50, x_C = x_D - 0.1 in [-0.72, 0.52] m:
  // colour columns u_C = 80 * x_C / 2 + 24 in [-4.8, 44.8] -> the rightmost column has no depth.
  int valid = 0;
  for (int v = 0; v < depth_C.rows; ++v) {
    for (int u = 0; u < depth_C.cols; ++u) {
      const uint16_t z = depth_C.at<uint16_t>(v, u);
      if (z == 0) continue;
      ++valid;
      EXPECT_EQ(z, 2000) << u << "," << v;
    }
    EXPECT_EQ(depth_C.at<uint16_t>(v, 47), 0) << "row " << v;
  }
  EXPECT_GT(valid, 300);
  EXPECT_EQ(depth_C.at<uint16_t>(17, 14), 2000);

  // A near object (a 1 m patch) in front of the plane wins the z-buffer where both land.
  depth_D(cv::Rect(14, 10, 4, 4)).setTo(1000);
  ASSERT_TRUE(registerDepthToColor(depth_D, K_depth, K_color, T_C_D, &depth_C).ok());
  // Colour pixel (u 14, v 17) gets the plane's depth pixel (12, 11) (u_C = 1.6 * 12 - 4.8 = 14.4)
  // and the patch's (14, 11) (x_C = -0.13 m at 1 m -> u_C = 13.6): the nearer wins.
  EXPECT_EQ(depth_C.at<uint16_t>(17, 14), 1000);

  // 65535 (saturated / invalid on Kinect-style sensors) is no depth, not a surface at 65 m.
  cv::Mat saturated(24, 32, CV_16UC1, cv::Scalar(0));
  saturated.at<uint16_t>(11, 15) = 65535;
  ASSERT_TRUE(registerDepthToColor(saturated, K_depth, K_color, T_C_D, &depth_C).ok());
  EXPECT_EQ(cv::countNonZero(depth_C), 0);
  saturated.at<uint16_t>(11, 15) = 65000;
  ASSERT_TRUE(registerDepthToColor(saturated, K_depth, K_color, T_C_D, &depth_C).ok());
  EXPECT_EQ(cv::countNonZero(depth_C), 1);
  ASSERT_TRUE(registerDepthToColor(depth_D, K_depth, K_color, T_C_D, &depth_C).ok());

  // Float metres in, the same out; bad input is an error.
  cv::Mat depth_m;
  depth_D.convertTo(depth_m, CV_32FC1, 1e-3);
  cv::Mat depth_C_from_m;
  ASSERT_TRUE(registerDepthToColor(depth_m, K_depth, K_color, T_C_D, &depth_C_from_m).ok());
  EXPECT_EQ(cv::norm(depth_C, depth_C_from_m, cv::NORM_INF), 0.0);
  EXPECT_FALSE(
      registerDepthToColor(cv::Mat(4, 4, CV_8UC1), K_depth, K_color, T_C_D, &depth_C).ok());
  CameraIntrinsics no_size = K_color;
  no_size.width = 0;
  EXPECT_FALSE(registerDepthToColor(depth_D, K_depth, no_size, T_C_D, &depth_C).ok());
}

}  // namespace
}  // namespace mvod
