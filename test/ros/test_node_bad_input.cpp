// rostest (node_bad_input.test): bad messages do not stop object_detection_node. Each one is
// reported on /rosout (WARN or ERROR, naming the problem), the frame is not processed, the services
// keep answering, and good frames afterwards are still mapped. Two nodes run: /object_detection
// takes its pose from a topic, /object_detection_tf from TF (for the missing-TF case).
#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <std_srvs/Trigger.h>
#include <sys/stat.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <mutex>
#include <string>

#include "multiview_object_detection/GetObjects.h"
#include "multiview_object_detection/MapFile.h"
#include "multiview_object_detection/ros/ros_params.h"
#include "test_node_common.h"

namespace mvod_test {
namespace {

using multiview_object_detection::GetObjects;

constexpr char kPoseNode[] = "/object_detection";
constexpr char kTfNode[] = "/object_detection_tf";
constexpr double kReportTimeoutS = 6.0;

class NodeBadInputTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nh_ = new ros::NodeHandle;
    SyntheticStream::Options options;
    stream_ = new SyntheticStream(options);
    inputs_ = new InputPublisher(*nh_);
    pose_node_ = new NodeOutputs(*nh_, kPoseNode, true);
    tf_node_ = new NodeOutputs(*nh_, kTfNode, true);
    connected_ = pose_node_->waitFor(
        [] { return inputs_->connected(2, 1) && pose_node_->connected() && tf_node_->connected(); },
        30.0);
    ros::WallDuration(1.0).sleep();  // /rosout connections
    // Whole seconds apart, so a report can be matched to its frame by the stamp's seconds.
    base_ = ros::Time(std::floor(ros::Time::now().toSec()));
  }
  static void TearDownTestSuite() {
    delete tf_node_;
    delete pose_node_;
    delete inputs_;
    delete stream_;
    delete nh_;
  }
  void SetUp() override { ASSERT_TRUE(connected_) << "the nodes' topics did not connect"; }

  static ros::Time stampAt(int seconds) { return base_ + ros::Duration(seconds); }

  // The node answers a service call (it is alive and not blocked).
  static bool answers(const std::string& node) {
    GetObjects srv;
    return ros::service::call(node + "/get_objects", srv);
  }

  // A pose for a later stamp on the pose topic (not TF), as a SLAM that keeps running sends: it
  // tells the node that no pose will come for older frames.
  static void publishLaterPose(int frame, const ros::Time& stamp) {
    FrameMsgs later = stream_->make(frame, stamp + ros::Duration(0.5));
    inputs_->pose_.publish(later.pose);
  }

  // Waits for a report of `node` after `since` containing all of `all` and one of `any`; on failure
  // the message lists what the node did log.
  static ::testing::AssertionResult reported(const NodeOutputs& node,
                                             const std::vector<std::string>& all,
                                             const std::vector<std::string>& any,
                                             const ros::Time& since) {
    if (node.waitFor([&] { return !node.findLogs(all, any, since).empty(); }, kReportTimeoutS)) {
      return ::testing::AssertionSuccess() << node.findLogs(all, any, since).front();
    }
    std::string words;
    for (const std::string& word : all) words += " '" + word + "'";
    words += " and one of";
    for (const std::string& word : any) words += " '" + word + "'";
    return ::testing::AssertionFailure() << "no WARN/ERROR with" << words << "; the node logged:\n"
                                         << node.allLogs();
  }

  static ros::NodeHandle* nh_;
  static SyntheticStream* stream_;
  static InputPublisher* inputs_;
  static NodeOutputs* pose_node_;
  static NodeOutputs* tf_node_;
  static bool connected_;
  static ros::Time base_;
};

ros::NodeHandle* NodeBadInputTest::nh_ = nullptr;
SyntheticStream* NodeBadInputTest::stream_ = nullptr;
InputPublisher* NodeBadInputTest::inputs_ = nullptr;
NodeOutputs* NodeBadInputTest::pose_node_ = nullptr;
NodeOutputs* NodeBadInputTest::tf_node_ = nullptr;
bool NodeBadInputTest::connected_ = false;
ros::Time NodeBadInputTest::base_;

TEST_F(NodeBadInputTest, WrongEncodingIsReported) {
  const ros::Time stamp = stampAt(1);
  FrameMsgs frame = stream_->make(0, stamp);
  cv::Mat gray(frame.rgb.height, frame.rgb.width, CV_8UC1, cv::Scalar(128));
  frame.rgb = toImageMsg(gray, "mono8", frame.rgb.header);
  const ros::Time since = ros::Time::now();
  inputs_->publish(frame, true, true, true);
  EXPECT_TRUE(reported(*pose_node_, {"encoding"}, {"mono8", "image_rect_color"}, since));
  EXPECT_TRUE(reported(*pose_node_, {"encoding", std::to_string(stamp.sec)}, {}, since))
      << "the report does not name the stamp";
  EXPECT_FALSE(pose_node_->hasObjectsAt(stamp));
  EXPECT_TRUE(answers(kPoseNode));
}

TEST_F(NodeBadInputTest, MismatchedImageSizesAreReported) {
  const ros::Time stamp = stampAt(2);
  FrameMsgs frame = stream_->make(0, stamp);
  cv::Mat small_depth(frame.rgb.height / 2, frame.rgb.width / 2, CV_16UC1, cv::Scalar(1500));
  frame.depth = toImageMsg(small_depth, "16UC1", frame.depth.header);
  const ros::Time since = ros::Time::now();
  inputs_->publish(frame, true, true, true);
  EXPECT_TRUE(reported(*pose_node_, {"size"}, {"image_rect", "depth", "160", "120"}, since));
  EXPECT_TRUE(reported(*pose_node_, {"size", std::to_string(stamp.sec)}, {}, since))
      << "the report does not name the stamp";
  EXPECT_FALSE(pose_node_->hasObjectsAt(stamp));
  EXPECT_TRUE(answers(kPoseNode));
}

TEST_F(NodeBadInputTest, InvalidCameraInfoIsReported) {
  const ros::Time stamp = stampAt(3);
  FrameMsgs frame = stream_->make(0, stamp);
  frame.info.K.fill(0.0);
  frame.info.P.fill(0.0);
  const ros::Time since = ros::Time::now();
  inputs_->publish(frame, true, true, true);
  EXPECT_TRUE(reported(*pose_node_, {}, {"camera_info", "intrinsic", "calibrat"}, since));
  EXPECT_FALSE(pose_node_->hasObjectsAt(stamp));
  EXPECT_TRUE(answers(kPoseNode));
}

// fx = fy = 15 px on 320x240: 169 degrees across, no RGB-D camera's (it made one keyframe take 40 s
// and 6.7 GB); refused with a report naming the camera_info topic, not mapped.
TEST_F(NodeBadInputTest, CameraInfoWithAFieldOfViewNoRgbdCameraHasIsReported) {
  const ros::Time stamp = stampAt(3) + ros::Duration(0.5);
  FrameMsgs frame = stream_->make(0, stamp);
  for (const int i : {0, 4}) frame.info.K[i] = 15.0;
  frame.info.P[0] = frame.info.P[5] = 15.0;
  const ros::Time since = ros::Time::now();
  inputs_->publish(frame, true, true, true);
  EXPECT_TRUE(reported(*pose_node_, {"camera_info", "field of view"}, {}, since));
  EXPECT_FALSE(pose_node_->hasObjectsAt(stamp));
  EXPECT_TRUE(answers(kPoseNode));
}

// Distortion: the node uses K only; a camera_info with non-zero D (unrectified images) is warned
// about, naming the topic and the rectified topics to use.
TEST_F(NodeBadInputTest, DistortedCameraInfoIsWarnedAbout) {
  const ros::Time stamp = stampAt(3) + ros::Duration(0.75);
  FrameMsgs frame = stream_->make(0, stamp);
  frame.info.distortion_model = "plumb_bob";
  frame.info.D = {0.1, -0.2, 0.0, 0.0, 0.0};
  const ros::Time since = ros::Time::now();
  inputs_->publish(frame, true, true, true);
  EXPECT_TRUE(reported(*pose_node_, {"camera_info", "distortion", "image_rect_color"}, {}, since));
  EXPECT_TRUE(answers(kPoseNode));
}

TEST_F(NodeBadInputTest, FrameWithoutPoseIsReported) {
  const ros::Time stamp = stampAt(4);
  const FrameMsgs frame = stream_->make(0, stamp);
  const ros::Time since = ros::Time::now();
  // Neither the pose topic nor TF for this stamp; TF's latest data is older (stamp 3), so a lookup
  // would have to extrapolate.
  inputs_->publish(frame, false, true, false);
  ros::WallDuration(0.3).sleep();
  publishLaterPose(0, stamp);
  EXPECT_TRUE(reported(*pose_node_, {"pose", "/slam/pose", std::to_string(stamp.sec)}, {}, since));
  EXPECT_FALSE(pose_node_->hasObjectsAt(stamp));
  EXPECT_TRUE(answers(kPoseNode));
  // The TF node has no TF for it either.
  EXPECT_TRUE(reported(*tf_node_, {std::to_string(stamp.sec)},
                       {"tf", "transform", "lookup", "extrapolat"}, since));
  EXPECT_FALSE(tf_node_->hasObjectsAt(stamp));
  EXPECT_TRUE(answers(kTfNode));
}

TEST_F(NodeBadInputTest, NanPoseIsReported) {
  const ros::Time stamp = stampAt(5);
  FrameMsgs frame = stream_->make(0, stamp);
  inputs_->publishTf(
      frame.pose);  // the TF node gets a good pose (it must not report missing TF here)
  frame.pose.pose.position.x = std::numeric_limits<double>::quiet_NaN();
  const ros::Time since = ros::Time::now();
  inputs_->publish(frame, true, true, false);
  publishLaterPose(0, stamp);
  EXPECT_TRUE(reported(*pose_node_, {"pose"}, {"nan", "invalid", "finite"}, since));
  EXPECT_TRUE(reported(*pose_node_, {"pose", std::to_string(stamp.sec)},
                       {"nan", "invalid", "finite"}, since))
      << "the report does not name the stamp";
  EXPECT_FALSE(pose_node_->hasObjectsAt(stamp));
  EXPECT_TRUE(answers(kPoseNode));
}

TEST_F(NodeBadInputTest, GoodFramesAfterBadOnesAreMapped) {
  // Three keyframes of the lap (keyframe_every_n 1), with pose, TF and detections. (Of the frames
  // before, only the distorted camera_info's is mapped: a warning, not a refusal.)
  const size_t before = pose_node_->keyframePoses();
  for (int i = 0; i < 3; ++i) {
    const ros::Time stamp = stampAt(10 + i);
    inputs_->publish(stream_->make(i, stamp), true, true, true);
    EXPECT_TRUE(pose_node_->waitForObjectsAt(stamp, 20.0)) << "frame " << i << " not processed\n"
                                                           << pose_node_->allLogs();
    EXPECT_TRUE(tf_node_->waitForObjectsAt(stamp, 20.0))
        << "frame " << i << " not processed (TF node)\n"
        << tf_node_->allLogs();
  }
  EXPECT_FALSE(pose_node_->lastObjects().objects.empty());
  EXPECT_FALSE(tf_node_->lastObjects().objects.empty());
  EXPECT_EQ(pose_node_->keyframePoses(), before + 3);
}

TEST_F(NodeBadInputTest, OutOfOrderFrameIsDroppedAndLaterFramesProcessed) {
  const size_t keyframes = pose_node_->keyframePoses();
  ASSERT_GT(keyframes, 0u) << "needs the good frames first";
  // Half a second older than the last processed frame (stamp 12): out of order. (More than 1 s
  // older is a jump back in time, below.)
  const ros::Time old_stamp = stampAt(12) - ros::Duration(0.5);
  const ros::Time since = ros::Time::now();
  inputs_->publish(stream_->make(5, old_stamp), true, true, true);
  EXPECT_TRUE(reported(*pose_node_, {}, {"older", "order"}, since));
  EXPECT_FALSE(pose_node_->hasObjectsAt(old_stamp));
  EXPECT_EQ(pose_node_->keyframePoses(), keyframes);

  const ros::Time new_stamp = stampAt(13);
  inputs_->publish(stream_->make(3, new_stamp), true, true, true);
  EXPECT_TRUE(pose_node_->waitForObjectsAt(new_stamp, 20.0)) << pose_node_->allLogs();
  EXPECT_EQ(pose_node_->keyframePoses(), keyframes + 1);
  EXPECT_TRUE(answers(kPoseNode));
  EXPECT_TRUE(answers(kTfNode));
}

// ---- Hostile input (issue 12) -------------------------------------------------------------------

// Calls a MapFile service; false when the call itself failed. `seconds` gets its duration.
bool callMapFile(const std::string& service, const std::string& path,
                 multiview_object_detection::MapFile* srv, double* seconds) {
  srv->request.path = path;
  const ros::WallTime start = ros::WallTime::now();
  const bool called = ros::service::call(service, *srv);
  *seconds = (ros::WallTime::now() - start).toSec();
  return called;
}

std::string testMapDirectory() {
  std::string directory;
  ros::param::get(std::string(kPoseNode) + "/map_directory", directory);
  return directory;
}

TEST_F(NodeBadInputTest, OneFutureStampDoesNotStopMapping) {
  ASSERT_GT(pose_node_->keyframePoses(), 0u) << "needs the good frames first";
  // A frame stamped a year ahead (a camera with a broken clock): images and detections only.
  const ros::Time future = stampAt(365 * 24 * 3600);
  const ros::Time since = ros::Time::now();
  inputs_->publish(stream_->make(4, future), false, true, false);
  ros::WallDuration(0.3).sleep();
  // Later frames with the right clock are mapped again, by both nodes.
  for (int i = 0; i < 2; ++i) {
    const ros::Time stamp = stampAt(20 + i);
    inputs_->publish(stream_->make(i, stamp), true, true, true);
    EXPECT_TRUE(pose_node_->waitForObjectsAt(stamp, 20.0)) << "frame " << i << "\n"
                                                           << pose_node_->allLogs();
    EXPECT_TRUE(tf_node_->waitForObjectsAt(stamp, 20.0)) << "frame " << i << " (TF node)\n"
                                                         << tf_node_->allLogs();
  }
  // Refused on the way in (a broken clock), not taken as a new timeline that every later frame
  // would then seem to jump back from.
  EXPECT_TRUE(reported(*pose_node_, {"refused", "ahead of the node's clock"}, {}, since));
  EXPECT_TRUE(pose_node_->findLogs({"jump back in time"}, {}, since).empty())
      << pose_node_->allLogs();
}

TEST_F(NodeBadInputTest, ReplayingFromAnEarlierStampWithoutResetIsMapped) {
  // A bag restarted without ~reset: time jumps back 6 s (within TF's 10 s cache, so the TF node
  // can follow too; a replay with --clock clears TF itself).
  for (const int second : {30, 31}) {
    inputs_->publish(stream_->make(second - 30, stampAt(second)), true, true, true);
    ASSERT_TRUE(pose_node_->waitForObjectsAt(stampAt(second), 20.0)) << pose_node_->allLogs();
  }
  const size_t keyframes = pose_node_->keyframePoses();
  for (const int second : {25, 26}) {
    const ros::Time stamp = stampAt(second);
    inputs_->publish(stream_->make(second - 25, stamp), true, true, true);
    EXPECT_TRUE(pose_node_->waitForObjectsAt(stamp, 20.0)) << second << "\n"
                                                           << pose_node_->allLogs();
    EXPECT_TRUE(tf_node_->waitForObjectsAt(stamp, 20.0)) << second << " (TF node)\n"
                                                         << tf_node_->allLogs();
  }
  EXPECT_EQ(pose_node_->keyframePoses(), keyframes + 2);
}

TEST_F(NodeBadInputTest, ResetClearsThePoseBufferSoARestartedBagIsMapped) {
  // A long run fills the pose buffer (2000 poses) with later stamps.
  FrameMsgs later = stream_->make(0, stampAt(100));
  for (int i = 0; i < 2100; ++i) {
    later.pose.header.stamp = stampAt(100) + ros::Duration(0.01 * i);
    inputs_->pose_.publish(later.pose);
    if (i % 200 == 0) ros::WallDuration(0.02).sleep();
  }
  ros::WallDuration(0.5).sleep();
  std_srvs::Trigger reset;
  ASSERT_TRUE(callService(std::string(kPoseNode) + "/reset", reset));
  ASSERT_TRUE(reset.response.success);
  const ros::Time stamp = stampAt(40);
  inputs_->publish(stream_->make(1, stamp), true, true, true);
  EXPECT_TRUE(pose_node_->waitForObjectsAt(stamp, 20.0)) << pose_node_->allLogs();
}

TEST_F(NodeBadInputTest, TwoThousandBoxesAreCappedAndServicesKeepAnswering) {
  const ros::Time stamp = stampAt(50);
  FrameMsgs frame = stream_->make(2, stamp);
  // 2000 whole-image boxes and two scores that are not probabilities (5: a percentage-style
  // detector; 1e30).
  const int width = static_cast<int>(frame.rgb.width);
  const int height = static_cast<int>(frame.rgb.height);
  multiview_object_detection::InstanceDetections& detections = frame.detections;
  const auto original_boxes = detections.boxes.size();
  for (int i = 0; i < 2000; ++i) {
    sensor_msgs::RegionOfInterest roi;
    roi.x_offset = static_cast<uint32_t>(i % 7);
    roi.y_offset = static_cast<uint32_t>(i % 5);
    roi.width = static_cast<uint32_t>(width);
    roi.height = static_cast<uint32_t>(height);
    detections.boxes.push_back(roi);
    if (!detections.class_ids.empty()) detections.class_ids.push_back(56);  // chair
    if (!detections.class_names.empty()) detections.class_names.push_back("chair");
    detections.scores.push_back(i == 0 ? 5.f : (i == 1 ? 1e30f : 0.55f));
  }
  detections.masks.clear();  // box-only
  ASSERT_GT(detections.boxes.size(), original_boxes);
  const ros::Time since = ros::Time::now();
  inputs_->publish(frame, true, true, true);
  // The services answer while the keyframe is processed.
  const ros::WallTime start = ros::WallTime::now();
  EXPECT_TRUE(answers(kPoseNode));
  EXPECT_LT((ros::WallTime::now() - start).toSec(), 5.0);
  EXPECT_TRUE(pose_node_->waitForObjectsAt(stamp, 120.0)) << pose_node_->allLogs();
  EXPECT_TRUE(reported(*pose_node_, {"max_detections_per_frame"}, {}, since));
  EXPECT_TRUE(reported(*pose_node_, {"not a probability"}, {}, since));

  // Whatever the map now holds saves and loads back.
  multiview_object_detection::MapFile srv;
  double seconds = 0.0;
  const std::string name = "bad_input_" + std::to_string(::getpid()) + ".json";
  ASSERT_TRUE(callMapFile(std::string(kPoseNode) + "/save_map", name, &srv, &seconds));
  ASSERT_TRUE(srv.response.success) << srv.response.message;
  ASSERT_TRUE(callMapFile(std::string(kPoseNode) + "/load_map", name, &srv, &seconds));
  EXPECT_TRUE(srv.response.success) << srv.response.message;
  std::filesystem::remove_all(testMapDirectory() + "/" + name.substr(0, name.size() - 5) +
                              ".mvmap");
}

TEST_F(NodeBadInputTest, BadMapFilesAreRefusedAtOnceAndTheMapIsKept) {
  const std::string directory = testMapDirectory();
  ASSERT_FALSE(directory.empty()) << "node_bad_input.test sets map_directory";
  std::filesystem::create_directories(directory);
  const std::string service = std::string(kPoseNode) + "/load_map";
  const std::string tag = std::to_string(::getpid());
  GetObjects before;
  ASSERT_TRUE(callService(std::string(kPoseNode) + "/get_objects", before));
  multiview_object_detection::MapFile srv;
  double seconds = 0.0;

  // A FIFO nobody writes to: refused at once, not after a writer appears.
  const std::string fifo = directory + "/fifo_" + tag + ".json";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  ASSERT_TRUE(callMapFile(service, fifo, &srv, &seconds));
  EXPECT_FALSE(srv.response.success);
  EXPECT_NE(srv.response.message.find("FIFO"), std::string::npos) << srv.response.message;
  EXPECT_LT(seconds, 5.0);
  std::remove(fifo.c_str());

  // A map with a point at 1e39 m (beyond float): refused, naming the field.
  const std::string huge = "huge_" + tag + ".json";
  {
    std::ofstream out(directory + "/" + huge);
    out << R"({"frames": 1, "keyframes": 1, "gravity_down": [0, 0, -1],
      "removed": {"atypical": 0, "intersecting": 0},
      "stage_ms": {"extraction": 0, "filter": 0, "lccp": 0, "manhattan": 0, "fusion": 0,
                   "refinement": 0, "total": 0},
      "objects": [{"id": 7, "class_name": "chair", "class_id": 56, "probability": 0.8,
        "observations": 1, "center": [1, 1, 0.5], "size": [0.5, 0.5, 0.9],
        "rotation": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "yaw": 0, "num_points": 1,
        "first_keyframe": 0, "last_keyframe": 0, "first_seen": 0, "last_seen": 0,
        "points": [[1e39, 0, 0]]}]})";
  }
  ASSERT_TRUE(callMapFile(service, huge, &srv, &seconds));
  EXPECT_FALSE(srv.response.success);
  EXPECT_NE(srv.response.message.find("points[0]"), std::string::npos) << srv.response.message;
  std::remove((directory + "/" + huge).c_str());

  // Paths outside map_directory are refused for saving and loading.
  ASSERT_TRUE(callMapFile(std::string(kPoseNode) + "/save_map", "/tmp/outside_" + tag + ".json",
                          &srv, &seconds));
  EXPECT_FALSE(srv.response.success);
  EXPECT_NE(srv.response.message.find("map_directory"), std::string::npos) << srv.response.message;
  EXPECT_FALSE(std::filesystem::exists("/tmp/outside_" + tag + ".json"));
  EXPECT_FALSE(std::filesystem::exists("/tmp/outside_" + tag + ".mvmap"));
  ASSERT_TRUE(callMapFile(service, "/etc/passwd", &srv, &seconds));
  EXPECT_FALSE(srv.response.success);

  // The map is what it was.
  GetObjects after;
  ASSERT_TRUE(callService(std::string(kPoseNode) + "/get_objects", after));
  EXPECT_EQ(after.response.objects.objects.size(), before.response.objects.objects.size());
}

// The node's parameters (read in one place, ros_params.cpp): paper_method applies first, and every
// single setting given as a parameter overrides it, wherever it is read; a wrong type is reported.
// Waits for `node`'s map status on /diagnostics at `level` or above whose message holds `words`;
// returns the message seen last ("" if none came).
std::string waitForMapStatus(ros::NodeHandle& nh, const std::string& node, int level,
                             const std::vector<std::string>& words, double timeout_s) {
  std::mutex mutex;
  std::string seen;
  bool found = false;
  const std::string name = node.substr(1) + ": map";  // diagnostic_updater: "<node>: <task>"
  ros::Subscriber sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 100, [&](const diagnostic_msgs::DiagnosticArray::ConstPtr& msg) {
        for (const diagnostic_msgs::DiagnosticStatus& status : msg->status) {
          if (status.name != name) continue;
          std::lock_guard<std::mutex> lock(mutex);
          seen = std::to_string(status.level) + " '" + status.message + "' (hardware_id '" +
                 status.hardware_id + "')";
          bool all = status.level >= level && status.hardware_id == node;
          for (const std::string& word : words)
            all = all && status.message.find(word) != std::string::npos;
          found = found || all;
        }
      });
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (ros::ok() && ros::WallTime::now() < deadline) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (found) return "found: " + seen;
    }
    ros::WallDuration(0.05).sleep();
  }
  sub.shutdown();
  std::lock_guard<std::mutex> lock(mutex);
  return seen;
}

// /diagnostics was "ok" while every frame was rejected (issue 47): now the map status is an ERROR
// with the share rejected and the reason, for frames and for camera poses.
TEST_F(NodeBadInputTest, DiagnosticsAreAnErrorWhileMostInputIsRejected) {
  // 30 at 10 Hz: most of the window's frames, whatever the tests before sent (10 s).
  for (int i = 0; i < 30; ++i) {
    FrameMsgs frame = stream_->make(0, stampAt(200 + i));
    cv::Mat gray(frame.rgb.height, frame.rgb.width, CV_8UC1, cv::Scalar(128));
    frame.rgb = toImageMsg(gray, "mono8", frame.rgb.header);
    inputs_->publish(frame, true, true, false);
    ros::WallDuration(0.08).sleep();
  }
  const std::string frames = waitForMapStatus(
      *nh_, kPoseNode, diagnostic_msgs::DiagnosticStatus::ERROR, {"frames rejected", "mono8"}, 5.0);
  EXPECT_EQ(frames.rfind("found: ", 0), 0u) << "last map status of " << kPoseNode << ": " << frames;
  // The TF node gets no TF for these stamps: its poses fail (it rejected the mono8 frames too).
  for (int i = 0; i < 5; ++i) {
    inputs_->publish(stream_->make(0, stampAt(240 + i)), true, true, false);
    ros::WallDuration(0.1).sleep();
  }
  const std::string poses = waitForMapStatus(*nh_, kTfNode, diagnostic_msgs::DiagnosticStatus::WARN,
                                             {"camera poses failed"}, 8.0);
  EXPECT_EQ(poses.rfind("found: ", 0), 0u) << "last map status of " << kTfNode << ": " << poses;
  EXPECT_TRUE(answers(kPoseNode));
}

// A bag replayed after ~reset sends the same TF stamps again: the node's TF buffer is cleared on
// reset, so the new transforms are used (not the old ones at the same stamps) and tf2 does not
// warn TF_REPEATED_DATA for each (issue 47).
TEST_F(NodeBadInputTest, ResetClearsTheTfBufferSoTheSameStampsGetTheirNewPoses) {
  const ros::Time stamp = stampAt(300);
  inputs_->publish(stream_->make(0, stamp), false, true, true);
  ASSERT_TRUE(tf_node_->waitForObjectsAt(stamp, 20.0)) << tf_node_->allLogs();
  std_srvs::Trigger reset;
  ASSERT_TRUE(callService(std::string(kTfNode) + "/reset", reset));
  ASSERT_TRUE(reset.response.success) << reset.response.message;
  ASSERT_TRUE(tf_node_->waitFor([] { return tf_node_->keyframePoses() == 0; }, 5.0));
  const ros::Time since = ros::Time::now();
  // The same stamp, another pose (frame 6 of the stream: elsewhere on its path).
  const FrameMsgs moved = stream_->make(6, stamp);
  inputs_->publish(moved, false, true, true);
  ASSERT_TRUE(tf_node_->waitFor([] { return tf_node_->keyframePoses() == 1; }, 20.0))
      << tf_node_->allLogs();
  const geometry_msgs::Pose keyframe = tf_node_->lastPath().poses.back().pose;
  EXPECT_NEAR(keyframe.position.x, moved.pose.pose.position.x, 1e-6);
  EXPECT_NEAR(keyframe.position.y, moved.pose.pose.position.y, 1e-6);
  EXPECT_NEAR(keyframe.position.z, moved.pose.pose.position.z, 1e-6);
  ros::WallDuration(0.5).sleep();
  EXPECT_TRUE(tf_node_->findLogs({"TF_REPEATED_DATA"}, {}, since).empty()) << tf_node_->allLogs();
}

// A static transform stamped by another clock (a static_transform_publisher on the wall clock
// beside a node on a bag's clock; make demo's view frame did this) is taken: look-ups ignore a
// static transform's stamp, so its distance from the node's clock says nothing (issue 56, first
// hour). Here it is 2 days ahead of the node's clock and holds the camera's pose.
TEST_F(NodeBadInputTest, AStaticTransformStampedByAnotherClockIsUsed) {
  const std::string camera = "camera_on_a_static_mount";
  const auto mounted = [&](const ros::Time& stamp) {
    FrameMsgs frame = stream_->make(2, stamp);
    frame.rgb.header.frame_id = camera;
    frame.depth.header.frame_id = camera;
    frame.info.header.frame_id = camera;
    frame.detections.header.frame_id = camera;
    return frame;
  };
  const FrameMsgs frame = mounted(stampAt(400));
  geometry_msgs::TransformStamped mount;
  mount.header.stamp = ros::Time::now() + ros::Duration(2 * 86400.0);
  mount.header.frame_id = kWorldFrame;
  mount.child_frame_id = camera;
  mount.transform.translation.x = frame.pose.pose.position.x;
  mount.transform.translation.y = frame.pose.pose.position.y;
  mount.transform.translation.z = frame.pose.pose.position.z;
  mount.transform.rotation = frame.pose.pose.orientation;
  tf2_ros::StaticTransformBroadcaster static_tf;
  const ros::Time since = ros::Time::now();
  static_tf.sendTransform(mount);
  // A frame a second until one is mapped (the first may reach the node before the transform does).
  bool mapped = false;
  for (int second = 400; second < 420 && !mapped; ++second) {
    inputs_->publish(mounted(stampAt(second)), false, true, false);
    mapped = tf_node_->waitForObjectsAt(stampAt(second), 1.0);
  }
  EXPECT_TRUE(mapped) << tf_node_->allLogs();
  EXPECT_TRUE(tf_node_->findLogs({"input refused"}, {}, since).empty()) << tf_node_->allLogs();
}

TEST(NodeParametersTest, PaperMethodFirstThenEachSettingGivenOverridesIt) {
  const auto read = [](const std::string& ns, std::vector<std::string>* errors) {
    return mvod::getObjectDetectionConfigFromRosParam(ros::NodeHandle(ns), errors);
  };
  std::vector<std::string> errors;
  const mvod::ObjectMapper::Config defaults = read("/params_defaults", &errors).mapper;
  EXPECT_TRUE(errors.empty());
  EXPECT_EQ(defaults.selection.selection, "consistent");
  EXPECT_EQ(defaults.lccp.implementation, "voxel_grid");
  EXPECT_EQ(defaults.extractor.min_consistent_neighbours, 3);

  ros::NodeHandle paper("/params_paper");
  paper.setParam("paper_method", true);
  const mvod::ObjectMapper::Config paper_config = read("/params_paper", &errors).mapper;
  EXPECT_TRUE(errors.empty());
  EXPECT_EQ(paper_config.selection.selection, "largest");
  EXPECT_EQ(paper_config.database.fusion, "paper");
  EXPECT_EQ(paper_config.lccp.implementation, "pcl");
  EXPECT_EQ(paper_config.extractor.min_consistent_neighbours, 0);

  // Settings read before and after the switch in the file both override it.
  ros::NodeHandle mixed("/params_paper_overridden");
  mixed.setParam("paper_method", true);
  mixed.setParam("extractor/min_consistent_neighbours", 2);
  mixed.setParam("lccp/implementation", std::string("voxel_grid"));
  const mvod::ObjectMapper::Config mixed_config = read("/params_paper_overridden", &errors).mapper;
  EXPECT_TRUE(errors.empty());
  EXPECT_EQ(mixed_config.selection.selection, "largest");
  EXPECT_EQ(mixed_config.extractor.min_consistent_neighbours, 2);
  EXPECT_EQ(mixed_config.lccp.implementation, "voxel_grid");

  ros::NodeHandle bad("/params_bad");
  bad.setParam("lccp/implementation", 5);
  const mvod::ObjectDetectionRosConfig bad_type = read("/params_bad", &errors);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("lccp/implementation"), std::string::npos) << errors[0];
  EXPECT_EQ(bad_type.mapper.lccp.implementation, "voxel_grid");  // the default stays
  errors.clear();
  bad.setParam("lccp/implementation", std::string("octree"));
  const mvod::ObjectDetectionRosConfig bad_value = read("/params_bad", &errors);
  EXPECT_TRUE(errors.empty());
  EXPECT_FALSE(bad_value.isValid().ok());
  EXPECT_NE(bad_value.isValid().message().find("implementation"), std::string::npos)
      << bad_value.isValid().message();
}

}  // namespace
}  // namespace mvod_test

int main(int argc, char** argv) {
  return mvod_test::runRosTests(argc, argv, "test_node_bad_input");
}
