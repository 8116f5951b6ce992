// dataset_to_bag end to end, no roscore: the tool runs on 3-frame synthetic folders (7-Scenes
// layout, registered and two-camera; SceneNN layout) and the bag is read back with rosbag::View:
// topics, counts, encodings, frames, stamps, poses and pixels against the dataset readers; bad
// usage exits 2, bad data exits 1 and leaves no bag; so do a full disk, a device as the output and
// stamps past 2^31 s, with a message rather than an abort.
#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sys/wait.h>
#include <tf2_msgs/TFMessage.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "multiview_object_detection/datasets/dataset.h"
#include "multiview_object_detection/datasets/scenenn_dataset.h"
#include "multiview_object_detection/detectors/file_instance_segmenter.h"
#include "multiview_object_detection/ros/conversions.h"
#include "multiview_object_detection/simulation/synthetic_scene.h"

#ifndef MVOD_DATASET_TO_BAG_BIN
#error "MVOD_DATASET_TO_BAG_BIN must be the path of the dataset_to_bag executable"
#endif

namespace mvod {
namespace {

namespace fs = std::filesystem;

struct ToolResult {
  int exit_code = -1;
  std::string stderr_text;
};

// shell_prefix: shell commands run before the tool (limits for it).
ToolResult runDatasetToBag(const std::string& args, const fs::path& work_dir,
                           const std::string& shell_prefix = "") {
  const fs::path log = work_dir / "stderr.txt";
  const std::string command = shell_prefix + std::string(MVOD_DATASET_TO_BAG_BIN) + " " + args +
                              " 2> '" + log.string() + "' > /dev/null";
  const int status = std::system(command.c_str());
  ToolResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  result.stderr_text = text.str();
  return result;
}

// Every message of the bag, by topic (instantiated as the type the topic should have).
struct BagContents {
  std::map<std::string, int> counts;
  std::map<std::string, std::string> types;
  std::vector<sensor_msgs::Image> color, depth;
  std::vector<sensor_msgs::CameraInfo> color_info;
  std::vector<geometry_msgs::PoseStamped> poses;
  std::vector<tf2_msgs::TFMessage> tf;
  std::vector<double> color_bag_times_s;
};

BagContents readBag(const fs::path& path) {
  BagContents contents;
  rosbag::Bag bag(path.string(), rosbag::bagmode::Read);
  rosbag::View view(bag);
  for (const rosbag::MessageInstance& m : view) {
    const std::string& topic = m.getTopic();
    ++contents.counts[topic];
    contents.types[topic] = m.getDataType();
    if (topic == "/camera/rgb/image_rect_color") {
      contents.color.push_back(*m.instantiate<sensor_msgs::Image>());
      contents.color_bag_times_s.push_back(m.getTime().toSec());
    } else if (topic == "/camera/depth_registered/image_rect") {
      contents.depth.push_back(*m.instantiate<sensor_msgs::Image>());
    } else if (topic == "/camera/rgb/camera_info") {
      contents.color_info.push_back(*m.instantiate<sensor_msgs::CameraInfo>());
    } else if (topic == "/orb_slam2_rgbd/pose") {
      contents.poses.push_back(*m.instantiate<geometry_msgs::PoseStamped>());
    } else if (topic == "/tf") {
      contents.tf.push_back(*m.instantiate<tf2_msgs::TFMessage>());
    }
  }
  return contents;
}

cv::Mat imageFromMsg(const sensor_msgs::Image& msg, int type) {
  cv::Mat image(static_cast<int>(msg.height), static_cast<int>(msg.width), type);
  const size_t row_bytes = image.cols * image.elemSize();
  EXPECT_EQ(msg.step, row_bytes);
  EXPECT_EQ(msg.data.size(), row_bytes * image.rows);
  if (msg.data.size() != row_bytes * image.rows) return cv::Mat();
  for (int r = 0; r < image.rows; ++r) {
    std::memcpy(image.ptr(r), msg.data.data() + r * row_bytes, row_bytes);
  }
  return image;
}

Eigen::Isometry3d poseFromMsg(const geometry_msgs::Pose& msg) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(msg.position.x, msg.position.y, msg.position.z);
  T.linear() =
      Eigen::Quaterniond(msg.orientation.w, msg.orientation.x, msg.orientation.y, msg.orientation.z)
          .toRotationMatrix();
  return T;
}

// Checks one frame of the bag against the frame the dataset reader loads. expected_depth: the
// depth the bag must hold (registered to the colour camera).
void expectFrameMatches(const BagContents& bag, size_t i, const RgbdFrame& frame,
                        const cv::Mat& expected_depth, const CameraIntrinsics& K_color,
                        double expected_stamp_s) {
  SCOPED_TRACE("bag frame " + std::to_string(i) + " (" + frame.name + ")");
  const sensor_msgs::Image& color = bag.color[i];
  const sensor_msgs::Image& depth = bag.depth[i];
  EXPECT_EQ(color.encoding, "bgr8");
  EXPECT_EQ(depth.encoding, "16UC1");
  EXPECT_EQ(color.header.frame_id, "camera_rgb_optical_frame");
  EXPECT_EQ(depth.header.frame_id, "camera_rgb_optical_frame");
  EXPECT_NEAR(color.header.stamp.toSec(), expected_stamp_s, 1e-6);
  EXPECT_NEAR(bag.color_bag_times_s[i], expected_stamp_s, 1e-6);
  EXPECT_EQ(depth.header.stamp, color.header.stamp);
  EXPECT_EQ(bag.color_info[i].header.stamp, color.header.stamp);
  EXPECT_EQ(bag.poses[i].header.stamp, color.header.stamp);
  ASSERT_EQ(bag.tf[i].transforms.size(), 1u);
  EXPECT_EQ(bag.tf[i].transforms[0].header.stamp, color.header.stamp);

  const cv::Mat color_image = imageFromMsg(color, CV_8UC3);
  ASSERT_FALSE(color_image.empty());
  EXPECT_EQ(cv::norm(color_image, frame.color_bgr, cv::NORM_INF), 0.0);
  const cv::Mat depth_image = imageFromMsg(depth, CV_16UC1);
  ASSERT_FALSE(depth_image.empty());
  ASSERT_EQ(depth_image.size(), expected_depth.size());
  EXPECT_EQ(cv::norm(depth_image, expected_depth, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::countNonZero(depth_image), depth_image.total() / 4);

  const sensor_msgs::CameraInfo& info = bag.color_info[i];
  EXPECT_EQ(info.width, static_cast<uint32_t>(frame.color_bgr.cols));
  EXPECT_EQ(info.height, static_cast<uint32_t>(frame.color_bgr.rows));
  EXPECT_DOUBLE_EQ(info.K[0], K_color.fx);
  EXPECT_DOUBLE_EQ(info.K[2], K_color.cx);
  EXPECT_DOUBLE_EQ(info.K[4], K_color.fy);
  EXPECT_DOUBLE_EQ(info.K[5], K_color.cy);

  // The colour camera's pose, on the pose topic and in TF.
  const Eigen::Isometry3d T_W_C = frame.T_W_D * frame.T_C_D.inverse();
  EXPECT_EQ(bag.poses[i].header.frame_id, "map");
  EXPECT_TRUE(poseFromMsg(bag.poses[i].pose).isApprox(T_W_C, 1e-9));
  const geometry_msgs::TransformStamped& tf = bag.tf[i].transforms[0];
  EXPECT_EQ(tf.header.frame_id, "map");
  EXPECT_EQ(tf.child_frame_id, "camera_rgb_optical_frame");
  geometry_msgs::Pose tf_pose;
  tf_pose.position.x = tf.transform.translation.x;
  tf_pose.position.y = tf.transform.translation.y;
  tf_pose.position.z = tf.transform.translation.z;
  tf_pose.orientation = tf.transform.rotation;
  EXPECT_TRUE(poseFromMsg(tf_pose).isApprox(T_W_C, 1e-9));
}

void expectTopicsAndCounts(const BagContents& bag, int frames) {
  const std::map<std::string, std::string> expected = {
      {"/camera/rgb/image_rect_color", "sensor_msgs/Image"},
      {"/camera/depth_registered/image_rect", "sensor_msgs/Image"},
      {"/camera/rgb/camera_info", "sensor_msgs/CameraInfo"},
      {"/camera/depth_registered/camera_info", "sensor_msgs/CameraInfo"},
      {"/orb_slam2_rgbd/pose", "geometry_msgs/PoseStamped"},
      {"/tf", "tf2_msgs/TFMessage"}};
  EXPECT_EQ(bag.types, expected);
  for (const auto& [topic, type] : expected) {
    EXPECT_EQ(bag.counts.count(topic) ? bag.counts.at(topic) : 0, frames) << topic;
  }
}

class DatasetToBagTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("mvod_dataset_to_bag_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    SyntheticSceneConfig config;
    config.num_frames = 3;
    config.K = CameraIntrinsics{262.5, 262.5, 159.5, 119.5, 320, 240};  // small: a fast test
    scene_ = std::make_unique<SyntheticScene>(SyntheticScene::makeDefault(config));
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path dir_;
  std::unique_ptr<SyntheticScene> scene_;
};

TEST_F(DatasetToBagTest, SevenScenesRegistered) {
  const fs::path data = dir_ / "data";
  ASSERT_TRUE(scene_->writeSevenScenes(data.string(), "").ok());
  const fs::path bag_path = dir_ / "out.bag";
  const ToolResult run =
      runDatasetToBag("--dataset " + data.string() + " --output " + bag_path.string(), dir_);
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  EXPECT_NE(run.stderr_text.find("3/3 frames"), std::string::npos) << run.stderr_text;
  // No colour intrinsics and no --registered: one camera is assumed, and said (issue 56), with
  // the options that give the colour camera or confirm one camera.
  for (const char* words :
       {"warning: ", "has no color-intrinsics.txt", "--color-intrinsics FILE", "--registered"}) {
    EXPECT_NE(run.stderr_text.find(words), std::string::npos) << words << "\n" << run.stderr_text;
  }

  const BagContents bag = readBag(bag_path);
  expectTopicsAndCounts(bag, 3);
  SevenScenesDataset dataset;
  ASSERT_TRUE(SevenScenesDataset::open(data.string(), &dataset).ok());
  ASSERT_EQ(dataset.frameIndices(), (std::vector<int>{0, 1, 2}));
  for (int index : dataset.frameIndices()) {
    RgbdFrame frame;
    ASSERT_TRUE(dataset.load(index, &frame).ok());
    // 7-Scenes: index / 30 s, plus the default 1 s offset.
    expectFrameMatches(bag, index, frame, frame.depth, frame.K_depth, 1.0 + index / 30.0);
  }
}

TEST_F(DatasetToBagTest, SevenScenesTwoCamerasRegistersDepthAndSelectsFrames) {
  const fs::path data = dir_ / "data";
  ASSERT_TRUE(scene_->writeSevenScenes(data.string(), "").ok());
  // The colour camera: another focal length, 2.5 cm beside the depth camera.
  std::ofstream(data / "color-intrinsics.txt") << "240 0 160\n0 240 120\n0 0 1\n";
  std::ofstream(data / "depth-to-color.txt") << "1 0 0 0.025\n0 1 0 0\n0 0 1 0\n0 0 0 1\n";
  const fs::path bag_path = dir_ / "out.bag";
  const ToolResult run =
      runDatasetToBag("--dataset " + data.string() + " --output " + bag_path.string() +
                          " --format 7scenes --first 1 --last 2 --rate-hz 10",
                      dir_);
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;

  const BagContents bag = readBag(bag_path);
  expectTopicsAndCounts(bag, 2);
  SevenScenesDataset dataset;
  ASSERT_TRUE(SevenScenesDataset::open(data.string(), &dataset).ok());
  ASSERT_FALSE(dataset.registered());
  for (int index : {1, 2}) {
    RgbdFrame frame;
    ASSERT_TRUE(dataset.load(index, &frame).ok());
    ASSERT_FALSE(frame.T_C_D.isApprox(Eigen::Isometry3d::Identity()));
    cv::Mat registered;
    ASSERT_TRUE(
        registerDepthToColor(frame.depth, frame.K_depth, frame.K_color, frame.T_C_D, &registered)
            .ok());
    // Registration changed the pixels: the bag must hold the registered depth, not the raw one.
    ASSERT_GT(cv::norm(registered, frame.depth, cv::NORM_L1), 0.0);
    expectFrameMatches(bag, index - 1, frame, registered, frame.K_color, 1.0 + index / 10.0);
  }
}

// The colour camera given from outside the dataset folder (a read-only mount), or the folder's
// colour files ignored with --registered (issue 47, item 3), as offline_detection takes them.
TEST_F(DatasetToBagTest, ColourCameraFromOutsideTheFolderOrRegistered) {
  const fs::path data = dir_ / "data_outside";
  ASSERT_TRUE(scene_->writeSevenScenes(data.string(), "").ok());
  const fs::path outside = dir_ / "colour_camera";
  fs::create_directories(outside);
  std::ofstream(outside / "K.txt") << "240 0 160\n0 240 120\n0 0 1\n";
  std::ofstream(outside / "T.txt") << "1 0 0 0.025\n0 1 0 0\n0 0 1 0\n0 0 0 1\n";
  const fs::path bag_path = dir_ / "outside.bag";
  ToolResult run = runDatasetToBag(
      "--dataset " + data.string() + " --output " + bag_path.string() +
          " --format 7scenes --first 1 --last 1 --rate-hz 10 --color-intrinsics " +
          (outside / "K.txt").string() + " --depth-to-color " + (outside / "T.txt").string(),
      dir_);
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  EXPECT_FALSE(fs::exists(data / "color-intrinsics.txt"));  // nothing written into the dataset
  SevenScenesDataset dataset;
  ColorCameraFiles camera;
  camera.color_intrinsics = (outside / "K.txt").string();
  camera.depth_to_color = (outside / "T.txt").string();
  ASSERT_TRUE(SevenScenesDataset::open(data.string(), &dataset, camera).ok());
  ASSERT_FALSE(dataset.registered());
  RgbdFrame frame;
  ASSERT_TRUE(dataset.load(1, &frame).ok());
  cv::Mat registered;
  ASSERT_TRUE(
      registerDepthToColor(frame.depth, frame.K_depth, frame.K_color, frame.T_C_D, &registered)
          .ok());
  expectFrameMatches(readBag(bag_path), 0, frame, registered, frame.K_color, 1.1);

  // The colour files in the folder, and --registered: they are not read; depth as recorded.
  fs::copy_file(outside / "K.txt", data / "color-intrinsics.txt");
  fs::copy_file(outside / "T.txt", data / "depth-to-color.txt");
  const fs::path registered_bag = dir_ / "registered.bag";
  run = runDatasetToBag("--dataset " + data.string() + " --output " + registered_bag.string() +
                            " --format 7scenes --first 1 --last 1 --rate-hz 10 --registered",
                        dir_);
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  EXPECT_EQ(run.stderr_text.find("warning"), std::string::npos) << run.stderr_text;
  ColorCameraFiles one_camera;
  one_camera.registered = true;
  ASSERT_TRUE(SevenScenesDataset::open(data.string(), &dataset, one_camera).ok());
  ASSERT_TRUE(dataset.registered());
  ASSERT_TRUE(dataset.load(1, &frame).ok());
  expectFrameMatches(readBag(registered_bag), 0, frame, frame.depth, frame.K_depth, 1.1);
}

TEST_F(DatasetToBagTest, SceneNNLayoutUsesTimestampsAndTrajectory) {
  // The synthetic frames written as a SceneNN sequence: image/, depth/, trajectory.log (block k-1
  // for image0000k), timestamp.txt (microseconds), asus.ini.
  const fs::path data = dir_ / "scenenn";
  fs::create_directories(data / "image");
  fs::create_directories(data / "depth");
  std::ofstream trajectory(data / "trajectory.log");
  std::ofstream stamps(data / "timestamp.txt");
  const long stamps_us[] = {5000000, 5033400, 5066100};
  for (int k = 1; k <= 3; ++k) {
    RgbdFrame rendered;
    scene_->render(k - 1, &rendered, nullptr);
    char number[16];
    std::snprintf(number, sizeof(number), "%05d", k);
    ASSERT_TRUE(cv::imwrite((data / "image" / ("image" + std::string(number) + ".png")).string(),
                            rendered.color_bgr));
    ASSERT_TRUE(cv::imwrite((data / "depth" / ("depth" + std::string(number) + ".png")).string(),
                            rendered.depth));
    trajectory << (k - 1) << " " << (k - 1) << " " << k << "\n";
    char row[160];
    for (int r = 0; r < 4; ++r) {
      const Eigen::Matrix4d M = rendered.T_W_D.matrix();
      std::snprintf(row, sizeof(row), "%.15f %.15f %.15f %.15f\n", M(r, 0), M(r, 1), M(r, 2),
                    M(r, 3));
      trajectory << row;
    }
    stamps << k << " " << stamps_us[k - 1] << " " << stamps_us[k - 1] + 200 << "\n";
  }
  trajectory.close();
  stamps.close();
  std::ofstream(data / "asus.ini") << "fx 262.5\nfy 262.5\ncx 159.5\ncy 119.5\n";

  const fs::path bag_path = dir_ / "out.bag";
  const ToolResult run = runDatasetToBag(
      "--dataset " + data.string() + " --output " + bag_path.string() + " --time-offset 0", dir_);
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  EXPECT_NE(run.stderr_text.find("scenenn"), std::string::npos) << run.stderr_text;

  const BagContents bag = readBag(bag_path);
  expectTopicsAndCounts(bag, 3);
  SceneNNDataset dataset;
  ASSERT_TRUE(SceneNNDataset::open(data.string(), &dataset).ok());
  for (int k = 1; k <= 3; ++k) {
    RgbdFrame frame;
    ASSERT_TRUE(dataset.load(k, &frame).ok());
    RgbdFrame rendered;
    scene_->render(k - 1, &rendered, nullptr);
    ASSERT_TRUE(frame.T_W_D.isApprox(rendered.T_W_D, 1e-9));
    expectFrameMatches(bag, k - 1, frame, frame.depth, frame.K_depth, stamps_us[k - 1] * 1e-6);
  }

  // More images than poses: the frame without one is an error before anything is written, and
  // --last converts the frames that have one.
  std::string blocks;
  {
    std::ifstream in(data / "trajectory.log");
    std::string line;
    for (int i = 0; i < 10 && std::getline(in, line); ++i) blocks += line + "\n";
  }
  std::ofstream(data / "trajectory.log") << blocks;
  fs::remove(bag_path);
  ToolResult bad =
      runDatasetToBag("--dataset " + data.string() + " --output " + bag_path.string(), dir_);
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.stderr_text.find("trajectory.log: no pose for frame 3"), std::string::npos)
      << bad.stderr_text;
  EXPECT_FALSE(fs::exists(bag_path));
  bad = runDatasetToBag(
      "--dataset " + data.string() + " --output " + bag_path.string() + " --last 2", dir_);
  ASSERT_EQ(bad.exit_code, 0) << bad.stderr_text;
  expectTopicsAndCounts(readBag(bag_path), 2);
}

// --detector records the detector's output per frame, stamped like the colour image, so the node's
// detector:=topic replays it.
TEST_F(DatasetToBagTest, RecordsDetectionsForTheTopicDetector) {
  const fs::path data = dir_ / "data";
  const fs::path detections = dir_ / "detections";
  ASSERT_TRUE(scene_->writeSevenScenes(data.string(), detections.string()).ok());
  const fs::path bag_path = dir_ / "out.bag";
  const ToolResult run =
      runDatasetToBag("--dataset " + data.string() + " --output " + bag_path.string() +
                          " --detector files --detections " + detections.string(),
                      dir_);
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  EXPECT_NE(run.stderr_text.find("detector:=topic"), std::string::npos) << run.stderr_text;

  rosbag::Bag bag(bag_path.string(), rosbag::bagmode::Read);
  std::map<double, multiview_object_detection::InstanceDetections> by_stamp;
  std::vector<double> color_stamps;
  for (const rosbag::MessageInstance& m : rosbag::View(bag)) {
    if (m.getTopic() == "/detections") {
      const auto msg = m.instantiate<multiview_object_detection::InstanceDetections>();
      ASSERT_TRUE(msg != nullptr) << m.getDataType();
      by_stamp[msg->header.stamp.toSec()] = *msg;
    } else if (m.getTopic() == "/camera/rgb/image_rect_color") {
      color_stamps.push_back(m.instantiate<sensor_msgs::Image>()->header.stamp.toSec());
    }
  }
  ASSERT_EQ(color_stamps.size(), 3u);
  ASSERT_EQ(by_stamp.size(), 3u);
  FileInstanceSegmenter files(detections.string());
  size_t total = 0;
  for (size_t i = 0; i < color_stamps.size(); ++i) {
    ASSERT_EQ(by_stamp.count(color_stamps[i]), 1u) << "no detections at a colour stamp";
    const auto& msg = by_stamp[color_stamps[i]];
    std::vector<Detection2D> expected;
    ASSERT_TRUE(files
                    .detect(cv::Mat(240, 320, CV_8UC3),
                            SevenScenesDataset::frameName(static_cast<int>(i)), &expected)
                    .ok());
    std::vector<Detection2D> replayed;
    ASSERT_TRUE(detectionsFromMsg(msg, cv::Size(320, 240), "/detections", &replayed).ok());
    ASSERT_EQ(replayed.size(), expected.size());
    for (size_t k = 0; k < expected.size(); ++k) {
      EXPECT_EQ(replayed[k].class_name, expected[k].class_name);
      EXPECT_FLOAT_EQ(replayed[k].score, expected[k].score);
      // The files give image-sized masks, the message's conversion box-sized ones: the same pixels.
      const cv::Rect image(0, 0, 320, 240);
      EXPECT_EQ(cv::norm(maskInRegion(replayed[k], image.size(), image),
                         maskInRegion(expected[k], image.size(), image), cv::NORM_INF),
                0.0);
    }
    total += expected.size();
  }
  EXPECT_GT(total, 3u);

  // A detector that cannot be created is a data error before anything is written; an unknown one
  // is a usage error.
  const std::string io = " --dataset " + data.string() + " --output " + bag_path.string();
  fs::remove(bag_path);
  EXPECT_EQ(runDatasetToBag(io + " --detector nonsense", dir_).exit_code, 2);
  EXPECT_EQ(runDatasetToBag(io + " --detections " + detections.string(), dir_).exit_code, 2);
  const ToolResult missing = runDatasetToBag(
      io + " --detector fastestdet --model-dir " + (dir_ / "no_models").string(), dir_);
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.stderr_text.find("FastestDet"), std::string::npos) << missing.stderr_text;
  EXPECT_FALSE(fs::exists(bag_path));
}

TEST_F(DatasetToBagTest, BadUsageAndBadData) {
  const fs::path data = dir_ / "data";
  ASSERT_TRUE(scene_->writeSevenScenes(data.string(), "").ok());
  const fs::path bag_path = dir_ / "out.bag";
  const std::string io = " --dataset " + data.string() + " --output " + bag_path.string();

  EXPECT_EQ(runDatasetToBag("--output " + bag_path.string(), dir_).exit_code, 2);
  EXPECT_EQ(runDatasetToBag("--dataset " + data.string(), dir_).exit_code, 2);
  EXPECT_EQ(runDatasetToBag(io + " --bogus 1", dir_).exit_code, 2);
  EXPECT_EQ(runDatasetToBag(io + " --rate-hz 0", dir_).exit_code, 2);
  EXPECT_EQ(runDatasetToBag(io + " --format tum", dir_).exit_code, 2);
  EXPECT_EQ(runDatasetToBag(io + " --first 5 --last 2", dir_).exit_code, 2);
  EXPECT_EQ(runDatasetToBag(io + " --last", dir_).exit_code, 2);
  // Names a bag could not be subscribed to with.
  for (const std::string bad : {"'1 bad//name'", "cam//era", "camera/", "9camera", "cam-era"}) {
    const ToolResult named = runDatasetToBag(io + " --camera " + bad, dir_);
    EXPECT_EQ(named.exit_code, 2) << bad;
    EXPECT_NE(named.stderr_text.find("not a valid ROS name"), std::string::npos)
        << named.stderr_text;
  }
  EXPECT_EQ(runDatasetToBag(io + " --pose-topic /slam//pose", dir_).exit_code, 2);
  EXPECT_FALSE(fs::exists(bag_path));

  ToolResult run = runDatasetToBag(
      "--dataset " + (dir_ / "nowhere").string() + " --output " + bag_path.string(), dir_);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.stderr_text.find("does not exist"), std::string::npos) << run.stderr_text;

  run = runDatasetToBag(io + " --first 10", dir_);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.stderr_text.find("no frames"), std::string::npos) << run.stderr_text;

  // A malformed pose of the last frame: exit 1, the message names the file, no bag is left.
  std::ofstream(data / "frame-000002.pose.txt") << "1 0 0\n";
  run = runDatasetToBag(io, dir_);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.stderr_text.find("frame-000002.pose.txt"), std::string::npos) << run.stderr_text;
  EXPECT_FALSE(fs::exists(bag_path));
  // Frames before it still convert.
  EXPECT_EQ(runDatasetToBag(io + " --last 1", dir_).exit_code, 0);
  EXPECT_EQ(readBag(bag_path).color.size(), 2u);
}

// Files the tool left in `dir` besides the dataset and its own log (a temporary bag).
std::vector<std::string> leftovers(const fs::path& dir) {
  std::vector<std::string> names;
  for (const fs::directory_entry& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name != "data" && name != "stderr.txt") names.push_back(name);
  }
  return names;
}

TEST_F(DatasetToBagTest, RatesAndStampsOutsideWhatRosTimeHoldsAreRefused) {
  const fs::path data = dir_ / "data";
  ASSERT_TRUE(scene_->writeSevenScenes(data.string(), "").ok());
  const fs::path bag_path = dir_ / "out.bag";
  const std::string io = " --dataset " + data.string() + " --output " + bag_path.string();

  // 1e-300 Hz put frame 1 at 1e300 s: ros::Time threw and the tool aborted.
  for (const std::string rate : {"1e-300", "0.001", "5000", "inf", "nan"}) {
    const ToolResult run = runDatasetToBag(io + " --rate-hz " + rate, dir_);
    EXPECT_EQ(run.exit_code, 2) << rate << ": " << run.stderr_text;
    EXPECT_NE(run.stderr_text.find("--rate-hz"), std::string::npos) << run.stderr_text;
  }
  EXPECT_EQ(runDatasetToBag(io + " --time-offset 1e300", dir_).exit_code, 2);
  EXPECT_TRUE(leftovers(dir_).empty());

  // An offset that takes frame 1 past 2^31 s: exit 1 naming the frame, nothing left behind.
  ToolResult run = runDatasetToBag(io + " --time-offset 2147483647.99", dir_);
  EXPECT_EQ(run.exit_code, 1) << run.stderr_text;
  EXPECT_NE(run.stderr_text.find("frame-000001"), std::string::npos) << run.stderr_text;
  EXPECT_NE(run.stderr_text.find("2^31"), std::string::npos) << run.stderr_text;
  EXPECT_TRUE(leftovers(dir_).empty());

  // The slowest rate allowed converts: frames 100 s apart.
  run = runDatasetToBag(io + " --rate-hz 0.01 --quiet", dir_);
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  const BagContents bag = readBag(bag_path);
  ASSERT_EQ(bag.color.size(), 3u);
  EXPECT_NEAR(bag.color[2].header.stamp.toSec(), 201.0, 1e-6);
  EXPECT_EQ(leftovers(dir_), std::vector<std::string>{"out.bag"});
}

TEST_F(DatasetToBagTest, WriteErrorsExitWithAMessageAndLeaveNoBag) {
  const fs::path data = dir_ / "data";
  ASSERT_TRUE(scene_->writeSevenScenes(data.string(), "").ok());
  const fs::path bag_path = dir_ / "out.bag";
  const std::string io = " --dataset " + data.string() + " --output " + bag_path.string();

  // A full disk: files may not grow past 32 KB (SIGXFSZ ignored, so writes fail with EFBIG).
  // rosbag's BagIOException went uncaught: the tool aborted.
  ToolResult run = runDatasetToBag(io, dir_, "trap '' XFSZ; ulimit -f 64; ");
  EXPECT_EQ(run.exit_code, 1) << run.stderr_text;
  EXPECT_NE(run.stderr_text.find("cannot"), std::string::npos) << run.stderr_text;
  EXPECT_NE(run.stderr_text.find("no bag written"), std::string::npos) << run.stderr_text;
  EXPECT_TRUE(leftovers(dir_).empty());  // neither out.bag nor the temporary bag

  // A device as the output (a link to /dev/full, so a tool that removed its output on failure
  // would remove the link, not the device): refused before anything is written.
  const fs::path device_link = dir_ / "full.bag";
  fs::create_symlink("/dev/full", device_link);
  run = runDatasetToBag(" --dataset " + data.string() + " --output " + device_link.string(), dir_);
  EXPECT_EQ(run.exit_code, 1) << run.stderr_text;
  EXPECT_NE(run.stderr_text.find("not a regular file"), std::string::npos) << run.stderr_text;
  EXPECT_TRUE(fs::is_character_file("/dev/full"));
  EXPECT_TRUE(fs::is_symlink(device_link));
  fs::remove(device_link);

  // A folder that does not exist, and a folder as the output.
  run = runDatasetToBag(
      " --dataset " + data.string() + " --output " + (dir_ / "nowhere" / "out.bag").string(), dir_);
  EXPECT_EQ(run.exit_code, 1) << run.stderr_text;
  EXPECT_NE(run.stderr_text.find("does not exist"), std::string::npos) << run.stderr_text;
  run = runDatasetToBag(" --dataset " + data.string() + " --output " + data.string(), dir_);
  EXPECT_EQ(run.exit_code, 1) << run.stderr_text;
  EXPECT_NE(run.stderr_text.find("not a regular file"), std::string::npos) << run.stderr_text;
  EXPECT_TRUE(leftovers(dir_).empty());

  // A complete bag replaces an old file only once it is complete.
  std::ofstream(bag_path) << "an old file";
  ASSERT_EQ(runDatasetToBag(io + " --quiet", dir_).exit_code, 0);
  EXPECT_EQ(readBag(bag_path).color.size(), 3u);
  EXPECT_EQ(leftovers(dir_), std::vector<std::string>{"out.bag"});
}

}  // namespace
}  // namespace mvod

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
