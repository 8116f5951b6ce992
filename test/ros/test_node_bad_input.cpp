// rostest (node_bad_input.test): bad messages do not stop object_detection_node. Each one is
// reported on /rosout (WARN or ERROR, naming the problem), the frame is not processed, the services
// keep answering, and good frames afterwards are still mapped. Two nodes run: /object_detection
// takes its pose from a topic, /object_detection_tf from TF (for the missing-TF case).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "multiview_object_detection/GetObjects.h"
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
  EXPECT_TRUE(reported(*pose_node_, {"encoding"}, {"mono8", "image_raw"}, since));
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
  EXPECT_TRUE(reported(*pose_node_, {"size"}, {"image_raw", "depth", "160", "120"}, since));
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
  // Three keyframes of the lap (keyframe_every_n 1), with pose, TF and detections.
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
  EXPECT_EQ(pose_node_->keyframePoses(), 3u);
}

TEST_F(NodeBadInputTest, OutOfOrderFrameIsDroppedAndLaterFramesProcessed) {
  const size_t keyframes = pose_node_->keyframePoses();
  ASSERT_GT(keyframes, 0u) << "needs the good frames first";
  const ros::Time old_stamp = stampAt(7);  // older than the last processed frame (stamp 12)
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

}  // namespace
}  // namespace mvod_test

int main(int argc, char** argv) {
  return mvod_test::runRosTests(argc, argv, "test_node_bad_input");
}
