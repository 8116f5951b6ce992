// SevenScenesDataset on tiny 7-Scenes-layout folders written by the test: open/load round trip,
// registered and two-camera datasets, every kind of bad file (the message must name it), the
// parsers' edge cases, and (when present) the real redkitchen data.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "multiview_object_detection/datasets/dataset.h"
#include "shared_data.h"
#include "test_files.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

std::string poseText(const Eigen::Isometry3d& T) {
  std::string text;
  char buffer[64];
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      std::snprintf(buffer, sizeof(buffer), "%.17g%s", T.matrix()(r, c), c < 3 ? " " : "\n");
      text += buffer;
    }
  }
  return text;
}

Eigen::Isometry3d testPose(int index) {
  return Eigen::Translation3d(0.1 * index, -0.2, 1.5) *
         Eigen::AngleAxisd(0.1 + 0.05 * index, Eigen::Vector3d(0.3, -1.0, 0.2).normalized());
}

cv::Mat testDepth(int index, int width = 8, int height = 6) {
  cv::Mat depth(height, width, CV_16UC1);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) depth.at<uint16_t>(v, u) = 1000 + 100 * index + 10 * v + u;
  }
  depth.at<uint16_t>(0, 0) = 0;
  depth.at<uint16_t>(1, 0) = 65535;
  return depth;
}

cv::Mat testColour(int index, int width = 8, int height = 6) {
  cv::Mat colour(height, width, CV_8UC3);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) colour.at<cv::Vec3b>(v, u) = cv::Vec3b(u * 20, v * 30, index);
  }
  return colour;
}

class SevenScenesDatasetTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::freshTestDir("mvod_dataset"); }
  void TearDown() override { fs::remove_all(dir_); }

  void writeText(const std::string& file, const std::string& text) {
    std::ofstream(dir_ / file) << text;
  }

  // Frames 0, 5 and 10 (PNG colour, lossless), depth K, plus files that are not frames.
  void writeDataset() {
    writeText("camera-intrinsics.txt",
              "5.850000000000000000e+02 0.000000000000000000e+00 3.200000000000000000e+02\n"
              "0.0 585.0 240.0\n0 0 1\n");
    for (const int index : {10, 0, 5}) {
      const std::string stem = SevenScenesDataset::frameName(index);
      ASSERT_TRUE(cv::imwrite((dir_ / (stem + ".depth.png")).string(), testDepth(index)));
      ASSERT_TRUE(cv::imwrite((dir_ / (stem + ".color.png")).string(), testColour(index)));
      writeText(stem + ".pose.txt", poseText(testPose(index)));
    }
    // Not frames: colour without depth, odd names.
    ASSERT_TRUE(cv::imwrite((dir_ / "frame-000003.color.png").string(), testColour(3)));
    writeText("frame-7.depth.png", "not a frame name");
    writeText("notes.txt", "hello");
  }

  SevenScenesDataset openOk() {
    SevenScenesDataset dataset;
    const Status status = SevenScenesDataset::open(dir_.string(), &dataset);
    EXPECT_TRUE(status.ok()) << status.message();
    return dataset;
  }

  // Expects load(index) to fail with a message containing every fragment.
  void expectLoadError(int index, const std::vector<std::string>& fragments) {
    SevenScenesDataset dataset = openOk();
    RgbdFrame frame;
    frame.name = "untouched";
    const Status status = dataset.load(index, &frame);
    ASSERT_FALSE(status.ok());
    for (const std::string& fragment : fragments) {
      EXPECT_NE(status.message().find(fragment), std::string::npos)
          << "'" << fragment << "' not in: " << status.message();
    }
    EXPECT_EQ(frame.name, "untouched");  // nothing written on failure
  }

  void expectOpenError(const std::vector<std::string>& fragments) {
    SevenScenesDataset dataset;
    const Status status = SevenScenesDataset::open(dir_.string(), &dataset);
    ASSERT_FALSE(status.ok());
    for (const std::string& fragment : fragments) {
      EXPECT_NE(status.message().find(fragment), std::string::npos)
          << "'" << fragment << "' not in: " << status.message();
    }
  }

  fs::path dir_;
};

TEST_F(SevenScenesDatasetTest, FrameName) {
  EXPECT_EQ(SevenScenesDataset::frameName(10), "frame-000010");
  EXPECT_EQ(SevenScenesDataset::frameName(0), "frame-000000");
  EXPECT_EQ(SevenScenesDataset::frameName(123456), "frame-123456");
}

TEST_F(SevenScenesDatasetTest, OpenAndLoadRoundTrip) {
  writeDataset();
  const SevenScenesDataset dataset = openOk();
  EXPECT_EQ(dataset.directory(), dir_.string());
  ASSERT_EQ(dataset.size(), 3u);
  EXPECT_EQ(dataset.frameIndices(), (std::vector<int>{0, 5, 10}));
  EXPECT_TRUE(dataset.registered());
  EXPECT_FALSE(dataset.hasGravity());
  EXPECT_DOUBLE_EQ(dataset.depthIntrinsics().fx, 585.0);
  EXPECT_DOUBLE_EQ(dataset.depthIntrinsics().fy, 585.0);
  EXPECT_DOUBLE_EQ(dataset.depthIntrinsics().cx, 320.0);
  EXPECT_DOUBLE_EQ(dataset.depthIntrinsics().cy, 240.0);
  EXPECT_DOUBLE_EQ(dataset.colorIntrinsics().fx, 585.0);

  for (const int index : {0, 5, 10}) {
    RgbdFrame frame;
    const Status status = dataset.load(index, &frame);
    ASSERT_TRUE(status.ok()) << status.message();
    EXPECT_EQ(frame.index, index);
    EXPECT_EQ(frame.name, SevenScenesDataset::frameName(index));
    EXPECT_DOUBLE_EQ(frame.stamp_s, index / 30.0);
    ASSERT_EQ(frame.depth.type(), CV_16UC1);
    ASSERT_EQ(frame.color_bgr.type(), CV_8UC3);
    EXPECT_EQ(cv::countNonZero(frame.depth != testDepth(index)), 0);
    cv::Mat diff;
    cv::absdiff(frame.color_bgr, testColour(index), diff);
    EXPECT_EQ(cv::countNonZero(diff.reshape(1)), 0);
    EXPECT_EQ(frame.K_depth.width, 8);
    EXPECT_EQ(frame.K_depth.height, 6);
    EXPECT_EQ(frame.K_color.width, 8);
    EXPECT_DOUBLE_EQ(frame.K_depth.cx, 320.0);
    EXPECT_TRUE(frame.registered);
    EXPECT_TRUE(frame.T_C_D.isApprox(Eigen::Isometry3d::Identity()));
    EXPECT_TRUE(frame.T_W_D.isApprox(testPose(index), 1e-12));
    EXPECT_TRUE(frame.validate().ok());
  }

  // A frame that is not there: the message names the missing file.
  RgbdFrame frame;
  const Status missing = dataset.load(4, &frame);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.message().find("frame-000004.color"), std::string::npos) << missing.message();
}

TEST_F(SevenScenesDatasetTest, TwoCameraDatasetWithGravity) {
  writeDataset();
  writeText("color-intrinsics.txt", "525 0 8.5\n0 526 5.5\n0 0 1\n");
  const Eigen::Isometry3d T_C_D =
      Eigen::Translation3d(0.025, 0.0, -0.001) * Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitY());
  writeText("depth-to-color.txt", poseText(T_C_D));
  writeText("gravity-direction.txt", "0.0 9.81 0\n");
  // Colour at twice the depth's resolution: fine for a two-camera dataset (every frame's colour
  // is the colour camera's size).
  for (const int index : {0, 5, 10}) {
    ASSERT_TRUE(cv::imwrite((dir_ / (SevenScenesDataset::frameName(index) + ".color.png")).string(),
                            testColour(index, 16, 12)));
  }

  const SevenScenesDataset dataset = openOk();
  EXPECT_FALSE(dataset.registered());
  EXPECT_DOUBLE_EQ(dataset.colorIntrinsics().fx, 525.0);
  EXPECT_DOUBLE_EQ(dataset.colorIntrinsics().fy, 526.0);
  EXPECT_TRUE(dataset.depthToColor().isApprox(T_C_D, 1e-12));
  ASSERT_TRUE(dataset.hasGravity());
  EXPECT_TRUE(dataset.gravityDown_W().isApprox(Eigen::Vector3d(0, 1, 0), 1e-12));

  RgbdFrame frame;
  const Status status = dataset.load(5, &frame);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_FALSE(frame.registered);
  EXPECT_EQ(frame.K_color.width, 16);
  EXPECT_EQ(frame.K_color.height, 12);
  EXPECT_EQ(frame.K_depth.width, 8);
  EXPECT_DOUBLE_EQ(frame.K_color.cx, 8.5);
  EXPECT_TRUE(frame.T_C_D.isApprox(T_C_D, 1e-12));

  // Without depth-to-color.txt the cameras are taken to coincide.
  fs::remove(dir_ / "depth-to-color.txt");
  const SevenScenesDataset identity = openOk();
  EXPECT_TRUE(identity.depthToColor().isApprox(Eigen::Isometry3d::Identity()));
}

// The colour camera's files given apart from a (read-only) dataset folder: they win over the
// folder's; --registered ignores the folder's colour files; a missing file is an error naming it.
TEST_F(SevenScenesDatasetTest, ColourCameraFilesApartFromTheFolder) {
  writeDataset();
  writeText("color-intrinsics.txt", "525 0 8.5\n0 526 5.5\n0 0 1\n");
  const fs::path elsewhere = dir_ / "calibration";
  fs::create_directories(elsewhere);
  std::ofstream(elsewhere / "K.txt") << "530 0 8\n0 530 6\n0 0 1\n";
  const Eigen::Isometry3d T_C_D(Eigen::Translation3d(0.029, 0.001, 0.0));
  std::ofstream(elsewhere / "T.txt") << poseText(T_C_D);
  for (const int index : {0, 5, 10}) {
    ASSERT_TRUE(cv::imwrite((dir_ / (SevenScenesDataset::frameName(index) + ".color.png")).string(),
                            testColour(index, 16, 12)));
  }
  ColorCameraFiles camera;
  camera.color_intrinsics = (elsewhere / "K.txt").string();
  camera.depth_to_color = (elsewhere / "T.txt").string();
  SevenScenesDataset dataset;
  ASSERT_TRUE(SevenScenesDataset::open(dir_.string(), &dataset, camera).ok());
  EXPECT_FALSE(dataset.registered());
  EXPECT_DOUBLE_EQ(dataset.colorIntrinsics().fx, 530.0);
  EXPECT_TRUE(dataset.depthToColor().isApprox(T_C_D, 1e-12));

  ColorCameraFiles registered;
  registered.registered = true;
  ASSERT_TRUE(SevenScenesDataset::open(dir_.string(), &dataset, registered).ok());
  EXPECT_TRUE(dataset.registered());
  EXPECT_DOUBLE_EQ(dataset.colorIntrinsics().fx, dataset.depthIntrinsics().fx);

  camera.color_intrinsics = (elsewhere / "missing.txt").string();
  const Status missing = SevenScenesDataset::open(dir_.string(), &dataset, camera);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.message().find("missing.txt"), std::string::npos) << missing.message();
}

TEST_F(SevenScenesDatasetTest, OpenErrorsNameTheFile) {
  {
    SevenScenesDataset dataset;
    const std::string missing = (dir_ / "no_such_folder").string();
    const Status status = SevenScenesDataset::open(missing, &dataset);
    ASSERT_FALSE(status.ok());
    EXPECT_NE(status.message().find(missing), std::string::npos) << status.message();
  }
  writeDataset();
  fs::remove(dir_ / "camera-intrinsics.txt");
  expectOpenError({"camera-intrinsics.txt", "no such file"});

  writeText("camera-intrinsics.txt", "585 0 320\n0 585 240\n0 0\n");
  expectOpenError({"camera-intrinsics.txt", "expected 9 numbers, found 8"});
  writeText("camera-intrinsics.txt", "585 0 320\n0 585 x240\n0 0 1\n");
  expectOpenError({"camera-intrinsics.txt", "x240"});
  writeText("camera-intrinsics.txt", "-585 0 320\n0 585 240\n0 0 1\n");
  expectOpenError({"camera-intrinsics.txt", "fx and fy"});
  writeText("camera-intrinsics.txt", "585 0 320\n0 585 240\n0 0 2\n");
  expectOpenError({"camera-intrinsics.txt", "pinhole"});
  writeText("camera-intrinsics.txt", "585 0 320\n0 585 240\n0 0 1\n");

  writeText("color-intrinsics.txt", "525 0 320 0 525 240 0 0 1 7\n");
  expectOpenError({"color-intrinsics.txt"});
  fs::remove(dir_ / "color-intrinsics.txt");

  writeText("depth-to-color.txt", poseText(Eigen::Isometry3d::Identity()));
  expectOpenError({"depth-to-color.txt", "color-intrinsics.txt"});
  fs::remove(dir_ / "depth-to-color.txt");

  for (const char* gravity : {"0 0 0\n", "1 2\n", "nan 0 1\n", "0 0 -1 0\n"}) {
    writeText("gravity-direction.txt", gravity);
    expectOpenError({"gravity-direction.txt"});
  }
  fs::remove(dir_ / "gravity-direction.txt");

  // A folder without frames.
  for (const int index : {0, 5, 10}) {
    fs::remove(dir_ / (SevenScenesDataset::frameName(index) + ".depth.png"));
  }
  expectOpenError({"no frame-NNNNNN.depth.png"});
}

TEST_F(SevenScenesDatasetTest, LoadErrorsNameTheFile) {
  writeDataset();
  // Malformed poses, one kind at a time on frame 5.
  const std::string pose_file = "frame-000005.pose.txt";
  const std::string good_pose = poseText(testPose(5));
  writeText(pose_file, "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0\n");
  expectLoadError(5, {pose_file, "expected 16 numbers, found 15"});
  writeText(pose_file, good_pose + "1\n");
  expectLoadError(5, {pose_file, "expected 16"});
  writeText(pose_file, "1 0 0 nan\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  expectLoadError(5, {pose_file, "non-finite"});
  writeText(pose_file, "1 0 0 -inf\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  expectLoadError(5, {pose_file, "non-finite"});
  writeText(pose_file, "2 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  expectLoadError(5, {pose_file, "rigid"});
  writeText(pose_file, "-1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");  // a reflection
  expectLoadError(5, {pose_file, "rigid"});
  writeText(pose_file, "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0.5 1\n");
  expectLoadError(5, {pose_file, "0 0 0 1"});
  fs::remove(dir_ / pose_file);
  expectLoadError(5, {pose_file, "no such file"});
  writeText(pose_file, good_pose);

  // 8-bit depth.
  const std::string depth_file = "frame-000005.depth.png";
  cv::Mat depth_8u;
  testDepth(5).convertTo(depth_8u, CV_8UC1, 1.0 / 256.0);
  ASSERT_TRUE(cv::imwrite((dir_ / depth_file).string(), depth_8u));
  expectLoadError(5, {depth_file, "8UC1", "16UC1"});

  // Wrong-size depth in a registered dataset.
  ASSERT_TRUE(cv::imwrite((dir_ / depth_file).string(), testDepth(5, 4, 3)));
  expectLoadError(5, {depth_file, "4x3", "8x6"});

  // Not an image at all.
  writeText(depth_file, "this is not a PNG");
  expectLoadError(5, {depth_file, "cannot read"});
  fs::remove(dir_ / depth_file);
  expectLoadError(5, {depth_file, "no such file"});

  // Missing and broken colour.
  fs::remove(dir_ / "frame-000010.color.png");
  expectLoadError(10, {"frame-000010.color", "no such file"});
  writeText("frame-000010.color.jpg", "garbage");
  expectLoadError(10, {"frame-000010.color.jpg", "cannot read"});

  // Frame 0 is still fine.
  SevenScenesDataset dataset = openOk();
  RgbdFrame frame;
  EXPECT_TRUE(dataset.load(0, &frame).ok());
  EXPECT_FALSE(dataset.load(0, nullptr).ok());
}

TEST_F(SevenScenesDatasetTest, ParsersEdgeCases) {
  const std::string path = (dir_ / "m.txt").string();
  Eigen::Matrix3d K;
  // Any whitespace, scientific notation, signs.
  writeText("m.txt", "  5.85e+02\t0 +3.2E2\r\n\n0 585.0 240\n 0 0 1   \n");
  ASSERT_TRUE(SevenScenesDataset::readMatrix3(path, &K).ok());
  EXPECT_DOUBLE_EQ(K(0, 0), 585.0);
  EXPECT_DOUBLE_EQ(K(0, 2), 320.0);
  EXPECT_DOUBLE_EQ(K(1, 2), 240.0);
  EXPECT_DOUBLE_EQ(K(2, 2), 1.0);

  for (const char* bad : {"", "1 2 3 4 5 6 7 8", "1 2 3 4 5 6 7 8 9 10", "1 2 3 4 5 6 7 8 9,",
                          "1 2 3 4 5 6 7 8 1e999", "1 2 3 4 5 6 7 8 inf"}) {
    writeText("m.txt", bad);
    const Status status = SevenScenesDataset::readMatrix3(path, &K);
    EXPECT_FALSE(status.ok()) << "'" << bad << "'";
    EXPECT_NE(status.message().find(path), std::string::npos) << status.message();
  }
  EXPECT_FALSE(SevenScenesDataset::readMatrix3((dir_ / "none.txt").string(), &K).ok());

  // A rotation printed with few decimals is accepted and snapped to an exact rotation.
  const std::string pose_path = (dir_ / "p.txt").string();
  writeText("p.txt",
            "0.9093129 0.2726223 -0.3142243 -0.3404563\n"
            "-0.2724862 0.9610498 0.0452796 0.0164698\n"
            "0.3143393 0.0444496 0.9482093 0.2965692\n"
            "0 0 0 1\n");
  Eigen::Isometry3d T;
  ASSERT_TRUE(SevenScenesDataset::readPose(pose_path, &T).ok());
  const Eigen::Matrix3d R = T.linear();
  EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
  // The nearest rotation: within the file's orthonormality error (~1e-4) of the printed numbers.
  EXPECT_NEAR(R(0, 0), 0.9093129, 5e-4);
  EXPECT_NEAR(R(1, 2), 0.0452796, 5e-4);
  EXPECT_DOUBLE_EQ(T.translation().x(), -0.3404563);
  EXPECT_DOUBLE_EQ(T.translation().z(), 0.2965692);

  // A rotation off by 5% is not rigid; a last row within 1e-3 of 0 0 0 1 is accepted.
  writeText("p.txt", "1.05 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  EXPECT_FALSE(SevenScenesDataset::readPose(pose_path, &T).ok());
  writeText("p.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0.0005 0 0 1.0005\n");
  EXPECT_TRUE(SevenScenesDataset::readPose(pose_path, &T).ok());
  writeText("p.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0.005 0 0 1\n");
  EXPECT_FALSE(SevenScenesDataset::readPose(pose_path, &T).ok());
}

// The real 7-Scenes redkitchen data, when the shared folder is next to the repository.
TEST(SevenScenesDatasetRealData, OpensRedkitchenAndLoadsFrameZero) {
  const fs::path data = test::sharedPath("data/7scenes_redkitchen/data");
  if (data.empty()) {
    GTEST_SKIP() << "7-Scenes data not found (set MVOD_SHARED_DIR or put shared/ next to the "
                    "repository): data/7scenes_redkitchen/data";
  }
  SevenScenesDataset dataset;
  const Status opened = SevenScenesDataset::open(data.string(), &dataset);
  ASSERT_TRUE(opened.ok()) << opened.message();
  EXPECT_GE(dataset.size(), 100u);
  EXPECT_EQ(dataset.frameIndices().front(), 0);
  EXPECT_DOUBLE_EQ(dataset.depthIntrinsics().fx, 585.0);
  if (dataset.hasGravity()) {
    EXPECT_NEAR(dataset.gravityDown_W().norm(), 1.0, 1e-12);
  }

  RgbdFrame frame;
  const Status loaded = dataset.load(0, &frame);
  ASSERT_TRUE(loaded.ok()) << loaded.message();
  EXPECT_EQ(frame.depth.cols, 640);
  EXPECT_EQ(frame.depth.rows, 480);
  EXPECT_EQ(frame.depth.type(), CV_16UC1);
  EXPECT_EQ(frame.color_bgr.type(), CV_8UC3);
  EXPECT_GT(cv::countNonZero(frame.depth), 640 * 480 / 2);
  EXPECT_TRUE(isValidPose(frame.T_W_D, 1e-9));
}

}  // namespace
}  // namespace mvod
