// rostest (node_hostile_headers.test): no header can kill object_detection_node. Stamps past 2038
// (where ROS 1 time arithmetic throws) on every input are refused with a report naming the input,
// then randomised headers (stamps, frame ids) on every input between good frames for ~fuzz_seconds
// (20 s in make test, 60 s in make test-sanitize: MVOD_FUZZ_SECONDS, node_hostile_headers.test).
// Two nodes: /object_detection (pose topic) and /object_detection_tf (TF). After each part, both
// nodes answer services and map good frames.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "test_node_common.h"

namespace mvod_test {
namespace {

using multiview_object_detection::GetObjects;

constexpr char kPoseNode[] = "/object_detection";
constexpr char kTfNode[] = "/object_detection_tf";
constexpr char kKeyframePosesTopic[] = "/slam/keyframe_poses";

class NodeHostileHeadersTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nh_ = new ros::NodeHandle;
    stream_ = new SyntheticStream(SyntheticStream::Options());
    inputs_ = new InputPublisher(*nh_);
    keyframe_poses_ = new ros::Publisher(nh_->advertise<nav_msgs::Path>(kKeyframePosesTopic, 10));
    pose_node_ = new NodeOutputs(*nh_, kPoseNode, true);
    tf_node_ = new NodeOutputs(*nh_, kTfNode, true);
    connected_ = pose_node_->waitFor(
        [] {
          return inputs_->connected(2, 1) && pose_node_->connected() && tf_node_->connected() &&
                 keyframe_poses_->getNumSubscribers() >= 2;
        },
        30.0);
    ros::WallDuration(1.0).sleep();  // /rosout connections
    next_second_ = static_cast<int>(std::floor(ros::Time::now().toSec()));
  }
  static void TearDownTestSuite() {
    delete tf_node_;
    delete pose_node_;
    delete keyframe_poses_;
    delete inputs_;
    delete stream_;
    delete nh_;
  }
  void SetUp() override { ASSERT_TRUE(connected_) << "the nodes' topics did not connect"; }

  static bool answers(const std::string& node) {
    GetObjects srv;
    return ros::service::call(node + "/get_objects", srv);
  }

  // A good frame with a fresh stamp (whole seconds after the last), on every input and TF.
  static ros::Time publishGoodFrame(int index) {
    const ros::Time stamp(static_cast<double>(++next_second_));
    inputs_->publish(stream_->make(index % stream_->options().num_frames, stamp), true, true, true);
    return stamp;
  }

  // Both nodes map a good frame published now.
  static void expectBothMapAGoodFrame(const std::string& context) {
    bool mapped_pose = false;
    bool mapped_tf = false;
    for (int attempt = 0; attempt < 3 && !(mapped_pose && mapped_tf); ++attempt) {
      next_second_ += 5;  // past anything a refused or jumped timeline left behind
      const ros::Time stamp = publishGoodFrame(attempt);
      mapped_pose = mapped_pose || pose_node_->waitForObjectsAt(stamp, 20.0);
      mapped_tf = mapped_tf || tf_node_->waitForObjectsAt(stamp, 20.0);
    }
    EXPECT_TRUE(mapped_pose) << context << ": the pose node maps no good frame\n"
                             << pose_node_->allLogs();
    EXPECT_TRUE(mapped_tf) << context << ": the TF node maps no good frame\n"
                           << tf_node_->allLogs();
    EXPECT_TRUE(answers(kPoseNode)) << context;
    EXPECT_TRUE(answers(kTfNode)) << context;
  }

  // Every input of one frame (and its TF and a keyframe_poses message) stamped `stamp`.
  static void publishEverythingAt(const ros::Time& stamp, const std::string& frame_id, int index) {
    FrameMsgs msgs = stream_->make(index % stream_->options().num_frames, stamp);
    if (!frame_id.empty() || index % 3 == 0) {
      for (std_msgs::Header* header : {&msgs.rgb.header, &msgs.depth.header, &msgs.info.header,
                                       &msgs.pose.header, &msgs.detections.header}) {
        header->frame_id = frame_id;
      }
    }
    nav_msgs::Path path;
    path.header = msgs.pose.header;
    path.poses.push_back(msgs.pose);
    keyframe_poses_->publish(path);
    inputs_->publish(msgs, true, true, true);
  }

  static ros::NodeHandle* nh_;
  static SyntheticStream* stream_;
  static InputPublisher* inputs_;
  static ros::Publisher* keyframe_poses_;
  static NodeOutputs* pose_node_;
  static NodeOutputs* tf_node_;
  static bool connected_;
  static int next_second_;
};

ros::NodeHandle* NodeHostileHeadersTest::nh_ = nullptr;
SyntheticStream* NodeHostileHeadersTest::stream_ = nullptr;
InputPublisher* NodeHostileHeadersTest::inputs_ = nullptr;
ros::Publisher* NodeHostileHeadersTest::keyframe_poses_ = nullptr;
NodeOutputs* NodeHostileHeadersTest::pose_node_ = nullptr;
NodeOutputs* NodeHostileHeadersTest::tf_node_ = nullptr;
bool NodeHostileHeadersTest::connected_ = false;
int NodeHostileHeadersTest::next_second_ = 0;

TEST_F(NodeHostileHeadersTest, StampsPast2038AreRefusedOnEveryInput) {
  expectBothMapAGoodFrame("before");
  const ros::Time since = ros::Time::now();
  for (const std::uint32_t sec : {2200000000u, 4000000000u, 4294967295u}) {
    const ros::Time bad(sec, 0);
    // The smallest repro of the crash: a pose stamped 4e9 s after one at a normal stamp.
    FrameMsgs pose_only = stream_->make(1, bad);
    inputs_->pose_.publish(pose_only.pose);
    // Detections alone, TF alone, keyframe poses alone, then everything.
    inputs_->detections_.publish(pose_only.detections);
    inputs_->publishTf(pose_only.pose);
    nav_msgs::Path path;
    path.header = pose_only.pose.header;
    path.poses.push_back(pose_only.pose);
    keyframe_poses_->publish(path);
    publishEverythingAt(bad, "", 2);
    ros::WallDuration(0.3).sleep();
    ASSERT_TRUE(answers(kPoseNode)) << "the pose node died at stamp " << sec;
    ASSERT_TRUE(answers(kTfNode)) << "the TF node died at stamp " << sec;
  }
  EXPECT_TRUE(pose_node_->waitFor(
      [&] {
        return !pose_node_->findLogs({"refused", "2038"}, {}, since).empty();
      },
      6.0))
      << pose_node_->allLogs();
  EXPECT_TRUE(tf_node_->waitFor(
      [&] {
        return !tf_node_->findLogs({"refused", "2038", "/tf"}, {}, since).empty();
      },
      6.0))
      << "no report naming /tf\n"
      << tf_node_->allLogs();
  expectBothMapAGoodFrame("after the stamps past 2038");
}

TEST_F(NodeHostileHeadersTest, HugeCoordinatesAreRefusedSoTheMapAlwaysReloads) {
  expectBothMapAGoodFrame("before");
  const ros::Time since = ros::Time::now();
  std::vector<ros::Time> far_stamps;
  for (const double x_m : {2e5, 1e6, 15000.0}) {
    FrameMsgs msgs = stream_->make(3, ros::Time(static_cast<double>(++next_second_)));
    msgs.pose.pose.position.x += x_m;
    inputs_->publish(msgs, true, true, true);
    far_stamps.push_back(msgs.pose.header.stamp);
  }
  EXPECT_TRUE(pose_node_->waitFor(
      [&] {
        return !pose_node_->findLogs({"beyond", "4900"}, {}, since).empty();
      },
      20.0))
      << pose_node_->allLogs();
  expectBothMapAGoodFrame("after the far poses");
  for (const ros::Time& stamp : far_stamps) {
    EXPECT_FALSE(pose_node_->hasObjectsAt(stamp)) << "a frame thousands of km out was mapped";
  }
  // Whatever the map holds reloads.
  EXPECT_EQ(copyMap(kPoseNode, kPoseNode), "");
  EXPECT_EQ(copyMap(kTfNode, kTfNode), "");
}

// A stamp of the fuzzer: edge values of ros::Time and plausible ones around the good frames.
ros::Time randomStamp(std::mt19937* rng, int now_s) {
  std::uniform_int_distribution<int> kind(0, 9);
  std::uniform_int_distribution<std::uint32_t> any_sec(0, UINT32_MAX);
  std::uniform_int_distribution<std::uint32_t> nsec(0, 999999999);
  std::uniform_int_distribution<int> near(-100000, 100000);
  switch (kind(*rng)) {
    case 0:
      return ros::Time(0, 0);
    case 1:
      return ros::Time(UINT32_MAX, 999999999);
    case 2:
      return ros::Time(2147483647u, nsec(*rng));  // 2038
    case 3:
      return ros::Time(any_sec(*rng), nsec(*rng));
    case 4:
      return ros::Time(static_cast<std::uint32_t>(now_s + 365 * 86400), 0);  // a year ahead
    case 5:
      return ros::Time(1, 0);
    case 6:
      return ros::Time(static_cast<std::uint32_t>(std::max(1, now_s + near(*rng))), 0);
    default:
      return ros::Time(static_cast<std::uint32_t>(std::max(1, now_s - 3)), nsec(*rng));
  }
}

std::string randomFrameId(std::mt19937* rng) {
  static const std::vector<std::string> ids = {
      "",     "map",      "camera_rgb_optical_frame", "/map",    "no_such_frame",
      "map ", "\xff\xfe", std::string(1000, 'x'),     "a/b/c/d", "odom"};
  return ids[std::uniform_int_distribution<std::size_t>(0, ids.size() - 1)(*rng)];
}

TEST_F(NodeHostileHeadersTest, RandomisedHeadersOnEveryInput) {
  double seconds = 20.0;
  ros::param::get("~fuzz_seconds", seconds);
  const unsigned seed = 20261127u;
  std::mt19937 rng(seed);
  SCOPED_TRACE("seed " + std::to_string(seed));
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(seconds);
  int good = 0;
  int hostile = 0;
  std::vector<ros::Time> good_stamps;
  while (ros::WallTime::now() < end && ros::ok()) {
    good_stamps.push_back(publishGoodFrame(good++));
    for (int k = 0; k < 4; ++k, ++hostile) {
      const ros::Time stamp = randomStamp(&rng, next_second_);
      const std::string frame_id = randomFrameId(&rng);
      FrameMsgs msgs = stream_->make(hostile % stream_->options().num_frames, stamp);
      for (std_msgs::Header* header : {&msgs.rgb.header, &msgs.depth.header, &msgs.info.header,
                                       &msgs.pose.header, &msgs.detections.header}) {
        header->frame_id = frame_id;
      }
      switch (std::uniform_int_distribution<int>(0, 6)(rng)) {
        case 0:
          inputs_->rgb_.publish(msgs.rgb);
          break;
        case 1:
          inputs_->depth_.publish(msgs.depth);
          break;
        case 2:
          inputs_->info_.publish(msgs.info);
          break;
        case 3:
          inputs_->pose_.publish(msgs.pose);
          break;
        case 4:
          inputs_->detections_.publish(msgs.detections);
          break;
        case 5:
          inputs_->publishTf(msgs.pose);
          break;
        default: {
          nav_msgs::Path path;
          path.header = msgs.pose.header;
          path.poses.push_back(msgs.pose);
          path.poses.back().header.stamp = randomStamp(&rng, next_second_);
          keyframe_poses_->publish(path);
        }
      }
    }
    ros::WallDuration(0.25).sleep();
  }
  ASSERT_TRUE(answers(kPoseNode)) << "the pose node died";
  ASSERT_TRUE(answers(kTfNode)) << "the TF node died";
  int mapped = 0;
  for (const ros::Time& stamp : good_stamps) mapped += pose_node_->hasObjectsAt(stamp) ? 1 : 0;
  std::printf(
      "[ INFO     ] %d good frames and %d hostile messages in %.0f s; the pose node mapped "
      "%d good frames\n",
      good, hostile, seconds, mapped);
  // The fuzzer's plausible stamps (a second or a day ahead) legitimately make the next good frames
  // look like a jump back in time, which drops what waits; most good frames are still mapped.
  EXPECT_GT(mapped, good / 4) << pose_node_->allLogs();
  expectBothMapAGoodFrame("after the randomised headers");
}

}  // namespace
}  // namespace mvod_test

int main(int argc, char** argv) {
  return mvod_test::runRosTests(argc, argv, "test_node_hostile_headers");
}
