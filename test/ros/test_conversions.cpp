// ROS <-> core conversions (ros/conversions.h) and the node's Config, without a roscore: messages
// are built in the test, converted, and checked field by field (round trips where a reverse
// exists).
#include <gtest/gtest.h>
#include <sensor_msgs/image_encodings.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <opencv2/imgproc.hpp>
#include <regex>
#include <set>
#include <stdexcept>

#include "multiview_object_detection/ObjectDetectionConfig.h"
#include "multiview_object_detection/pipeline/types/class_priors.h"
#include "multiview_object_detection/pipeline/types/parameter_ranges.h"
#include "multiview_object_detection/ros/conversions.h"
#include "multiview_object_detection/ros/frame_gaps.h"
#include "multiview_object_detection/ros/input_monitor.h"
#include "multiview_object_detection/ros/markers.h"
#include "multiview_object_detection/ros/object_detection_ros_config.h"
#include "multiview_object_detection/ros/reconfigure_names.h"
#include "multiview_object_detection/ros/rejection_window.h"
#include "multiview_object_detection/ros/ros_params.h"
#include "multiview_object_detection/ros/service_answering.h"
#include "multiview_object_detection/ros/tf_stamp_check.h"

namespace mvod {
namespace {

namespace enc = sensor_msgs::image_encodings;

std_msgs::Header makeHeader(const std::string& frame, double stamp_s) {
  std_msgs::Header header;
  header.frame_id = frame;
  header.stamp = ros::Time(stamp_s);
  return header;
}

// A packed image message of the given encoding with bytes from `mat` (continuous).
sensor_msgs::ImagePtr imageMsg(const cv::Mat& mat, const std::string& encoding,
                               double stamp_s = 5.0) {
  sensor_msgs::ImagePtr msg(new sensor_msgs::Image);
  msg->header = makeHeader("camera_rgb_optical_frame", stamp_s);
  msg->encoding = encoding;
  msg->width = static_cast<uint32_t>(mat.cols);
  msg->height = static_cast<uint32_t>(mat.rows);
  msg->step = static_cast<uint32_t>(mat.cols * mat.elemSize());
  msg->data.resize(static_cast<size_t>(msg->step) * msg->height);
  for (int r = 0; r < mat.rows; ++r) {
    std::memcpy(&msg->data[static_cast<size_t>(r) * msg->step], mat.ptr(r), msg->step);
  }
  return msg;
}

sensor_msgs::CameraInfoPtr cameraInfo(double fx, double fy, double cx, double cy, int width,
                                      int height) {
  sensor_msgs::CameraInfoPtr info(new sensor_msgs::CameraInfo);
  info->header = makeHeader("camera_rgb_optical_frame", 5.0);
  info->width = static_cast<uint32_t>(width);
  info->height = static_cast<uint32_t>(height);
  info->K = {fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0};
  return info;
}

// A gravity-aligned box rotated by yaw about z.
MapObject makeObject(int id, const std::string& class_name, const Eigen::Vector3d& center,
                     const Eigen::Vector3d& size, double yaw_rad) {
  MapObject object;
  object.id = id;
  object.class_name = class_name;
  object.class_id = cocoClassId(class_name);
  object.probability = 0.87;
  object.observations = 4;
  object.box.center_m = center;
  object.box.size_m = size;
  object.box.rotation = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  object.yaw_rad = yaw_rad;
  object.first_seen_s = 10.5;
  object.last_seen_s = 20.25;
  // A small cloud on the box: a grid over its top face.
  for (int i = 0; i < 5; ++i) {
    for (int j = 0; j < 4; ++j) {
      const Eigen::Vector3d p_B((i / 4.0 - 0.5) * size.x(), (j / 3.0 - 0.5) * size.y(),
                                0.5 * size.z());
      object.segment_W.push_back((object.box.rotation * p_B + center).cast<float>());
    }
  }
  object.points_W = object.segment_W;
  return object;
}

Detection2D makeDetection(const std::string& class_name, float score, const cv::Rect& box,
                          const cv::Size& image_size) {
  Detection2D d;
  d.class_name = class_name;
  d.class_id = cocoClassId(class_name);
  d.score = score;
  d.box_px = box;
  d.mask = cv::Mat::zeros(image_size, CV_8UC1);
  // An ellipse inside the box: not the filled box, so a lost mask would show.
  cv::ellipse(d.mask, cv::Point(box.x + box.width / 2, box.y + box.height / 2),
              cv::Size(box.width / 2 - 1, box.height / 2 - 1), 0, 0, 360, cv::Scalar(255), -1);
  return d;
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

}  // namespace

// ---- Images -----------------------------------------------------------------------------------

TEST(RosConversionsTest, ColorRgb8IsSwappedToBgrAndBgr8Kept) {
  cv::Mat rgb(4, 6, CV_8UC3, cv::Scalar(10, 20, 30));  // R=10 G=20 B=30
  rgb.at<cv::Vec3b>(2, 3) = cv::Vec3b(200, 100, 50);
  cv::Mat bgr;
  ASSERT_TRUE(colorImageFromMsg(*imageMsg(rgb, enc::RGB8), "rgb/image_raw", &bgr).ok());
  ASSERT_EQ(bgr.type(), CV_8UC3);
  ASSERT_EQ(bgr.size(), cv::Size(6, 4));
  EXPECT_EQ(bgr.at<cv::Vec3b>(0, 0), cv::Vec3b(30, 20, 10));
  EXPECT_EQ(bgr.at<cv::Vec3b>(2, 3), cv::Vec3b(50, 100, 200));

  ASSERT_TRUE(colorImageFromMsg(*imageMsg(rgb, enc::BGR8), "rgb/image_raw", &bgr).ok());
  EXPECT_EQ(bgr.at<cv::Vec3b>(2, 3), cv::Vec3b(200, 100, 50));
}

TEST(RosConversionsTest, WrongColorEncodingNamesTopicFrameStampAndEncoding) {
  cv::Mat mono(4, 6, CV_8UC1, cv::Scalar(7));
  cv::Mat bgr;
  const Status status = colorImageFromMsg(*imageMsg(mono, enc::MONO8, 12.5), "rgb/image_raw", &bgr);
  ASSERT_FALSE(status.ok());
  EXPECT_TRUE(contains(status.message(), "rgb/image_raw")) << status.message();
  EXPECT_TRUE(contains(status.message(), "mono8")) << status.message();
  EXPECT_TRUE(contains(status.message(), "camera_rgb_optical_frame")) << status.message();
  EXPECT_TRUE(contains(status.message(), "12.5")) << status.message();
  EXPECT_TRUE(bgr.empty());
}

TEST(RosConversionsTest, DepthEncodingsKeepValuesAndUnits) {
  cv::Mat mm(3, 5, CV_16UC1, cv::Scalar(0));
  mm.at<uint16_t>(1, 2) = 1234;
  cv::Mat depth;
  ASSERT_TRUE(depthImageFromMsg(*imageMsg(mm, enc::TYPE_16UC1), "depth", &depth).ok());
  ASSERT_EQ(depth.type(), CV_16UC1);
  EXPECT_EQ(depth.at<uint16_t>(1, 2), 1234);
  ASSERT_TRUE(depthImageFromMsg(*imageMsg(mm, enc::MONO16), "depth", &depth).ok());
  ASSERT_EQ(depth.type(), CV_16UC1);
  EXPECT_EQ(depth.at<uint16_t>(1, 2), 1234);

  cv::Mat m(3, 5, CV_32FC1, cv::Scalar(0.f));
  m.at<float>(2, 4) = 2.5f;
  m.at<float>(0, 0) = std::numeric_limits<float>::quiet_NaN();
  ASSERT_TRUE(depthImageFromMsg(*imageMsg(m, enc::TYPE_32FC1), "depth", &depth).ok());
  ASSERT_EQ(depth.type(), CV_32FC1);
  EXPECT_FLOAT_EQ(depth.at<float>(2, 4), 2.5f);
  EXPECT_TRUE(std::isnan(depth.at<float>(0, 0)));

  const Status wrong = depthImageFromMsg(*imageMsg(cv::Mat(3, 5, CV_8UC3), enc::BGR8),
                                         "depth_registered/image_raw", &depth);
  ASSERT_FALSE(wrong.ok());
  EXPECT_TRUE(contains(wrong.message(), "depth_registered/image_raw"));
  EXPECT_TRUE(contains(wrong.message(), "bgr8"));
}

TEST(RosConversionsTest, TruncatedOrMalformedImagesAreErrorsNotCrashes) {
  sensor_msgs::ImagePtr msg = imageMsg(cv::Mat(8, 8, CV_8UC3, cv::Scalar(1, 2, 3)), enc::BGR8);
  msg->data.resize(msg->data.size() / 2);
  cv::Mat bgr;
  EXPECT_FALSE(colorImageFromMsg(*msg, "rgb", &bgr).ok());

  msg = imageMsg(cv::Mat(8, 8, CV_8UC3), enc::BGR8);
  msg->step = 3;  // smaller than a row
  EXPECT_FALSE(colorImageFromMsg(*msg, "rgb", &bgr).ok());

  msg = imageMsg(cv::Mat(8, 8, CV_8UC3), enc::BGR8);
  msg->width = 0;
  EXPECT_FALSE(colorImageFromMsg(*msg, "rgb", &bgr).ok());

  msg = imageMsg(cv::Mat(8, 8, CV_16UC1), "not_an_encoding");
  cv::Mat depth;
  EXPECT_FALSE(depthImageFromMsg(*msg, "depth", &depth).ok());
}

TEST(RosConversionsTest, CameraInfoAllZeroKIsRejected) {
  sensor_msgs::CameraInfo info = *cameraInfo(0, 0, 0, 0, 640, 480);
  info.K.fill(0.0);
  CameraIntrinsics K;
  const Status zero = intrinsicsFromCameraInfo(info, "rgb/camera_info", &K);
  ASSERT_FALSE(zero.ok());
  EXPECT_TRUE(contains(zero.message(), "rgb/camera_info"));
  EXPECT_TRUE(contains(zero.message(), "all zero"));
  EXPECT_FALSE(K.isValid());  // untouched

  info.K[2] = 320;  // cx only: fx = 0
  EXPECT_FALSE(intrinsicsFromCameraInfo(info, "rgb/camera_info", &K).ok());
  info = *cameraInfo(525, 520, 319.5, 239.5, 640, 480);
  info.K[4] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(intrinsicsFromCameraInfo(info, "rgb/camera_info", &K).ok());

  ASSERT_TRUE(
      intrinsicsFromCameraInfo(*cameraInfo(525, 520, 319.5, 239.5, 640, 480), "info", &K).ok());
  EXPECT_DOUBLE_EQ(K.fx, 525);
  EXPECT_DOUBLE_EQ(K.fy, 520);
  EXPECT_DOUBLE_EQ(K.cx, 319.5);
  EXPECT_DOUBLE_EQ(K.cy, 239.5);
  EXPECT_EQ(K.width, 640);
  EXPECT_EQ(K.height, 480);
}

// A camera_info no RGB-D camera has is refused before any pixel is copied, the message naming its
// topic: fx = fy = 30 px on 640x480 (169 degrees across) made one keyframe take 40 s and 6.7 GB.
TEST(RosConversionsTest, CameraInfoNoRgbdCameraHasIsRejectedNamingTheTopic) {
  const cv::Size size(640, 480);
  RgbdMessages msgs;
  msgs.color = imageMsg(cv::Mat(size, CV_8UC3, cv::Scalar(1, 2, 3)), enc::BGR8, 7.25);
  msgs.depth = imageMsg(cv::Mat(size, CV_16UC1, cv::Scalar(1500)), enc::TYPE_16UC1, 7.25);
  msgs.color_info = cameraInfo(525, 525, 319.5, 239.5, size.width, size.height);
  const RgbdTopics topics;
  ASSERT_TRUE(checkRgbdMessages(msgs, topics).ok());

  auto expectRefused = [&](const std::vector<std::string>& fragments) {
    const Status checked = checkRgbdMessages(msgs, topics);
    ASSERT_FALSE(checked.ok());
    for (const std::string& fragment : fragments) {
      EXPECT_TRUE(contains(checked.message(), fragment))
          << "'" << fragment << "' not in: " << checked.message();
    }
    RgbdFrame frame;
    EXPECT_FALSE(rgbdFrameFromMsgs(msgs, topics, Eigen::Isometry3d::Identity(),
                                   Eigen::Isometry3d::Identity(), &frame)
                     .ok());
  };
  // Far too wide, too narrow, too wide only up and down.
  msgs.color_info = cameraInfo(30, 30, 319.5, 239.5, size.width, size.height);
  expectRefused({"rgb/camera_info", "field of view", "169"});
  msgs.color_info = cameraInfo(3000, 3000, 319.5, 239.5, size.width, size.height);
  expectRefused({"rgb/camera_info", "field of view"});
  msgs.color_info = cameraInfo(525, 10, 319.5, 239.5, size.width, size.height);
  expectRefused({"rgb/camera_info", "field of view"});
  // The principal point outside the image.
  msgs.color_info = cameraInfo(525, 525, 700, 239.5, size.width, size.height);
  expectRefused({"rgb/camera_info", "principal point"});
  // A camera_info for another size; one that gives no size has its K checked against the image.
  msgs.color_info = cameraInfo(262.5, 262.5, 159.5, 119.5, 320, 240);
  expectRefused({"rgb/camera_info", "320x240", "640x480"});
  msgs.color_info = cameraInfo(5250, 5250, 319.5, 239.5, 0, 0);
  expectRefused({"rgb/camera_info", "field of view"});

  // Unregistered depth: its own camera_info is checked against the depth image.
  msgs.color_info = cameraInfo(525, 525, 319.5, 239.5, size.width, size.height);
  msgs.depth = imageMsg(cv::Mat(240, 320, CV_16UC1, cv::Scalar(1500)), enc::TYPE_16UC1, 7.25);
  msgs.depth_info = cameraInfo(262.5, 262.5, 159.5, 119.5, 320, 240);
  ASSERT_TRUE(checkRgbdMessages(msgs, topics).ok());
  msgs.depth_info = cameraInfo(15, 15, 159.5, 119.5, 320, 240);
  expectRefused({"depth/camera_info", "field of view"});
}

TEST(RosConversionsTest, DistortedCameraInfoGivesAWarningNamingTheTopic) {
  sensor_msgs::CameraInfo info = *cameraInfo(525, 525, 319.5, 239.5, 640, 480);
  info.D.clear();
  EXPECT_EQ(distortionWarning(info, "/camera/rgb/camera_info"), "");
  info.distortion_model = "plumb_bob";
  info.D.assign(5, 0.0);
  EXPECT_EQ(distortionWarning(info, "/camera/rgb/camera_info"), "");
  info.D[0] = 0.2624;
  info.D[1] = -0.9531;
  const std::string warning = distortionWarning(info, "/camera/rgb/camera_info");
  EXPECT_TRUE(contains(warning, "/camera/rgb/camera_info")) << warning;
  EXPECT_TRUE(contains(warning, "plumb_bob D = [0.2624, -0.9531, 0, 0, 0]")) << warning;
  EXPECT_TRUE(contains(warning, "rgb/image_rect_color")) << warning;
}

TEST(RosConversionsTest, RgbdFrameRegisteredAndUnregistered) {
  const cv::Size size(8, 6);
  RgbdMessages msgs;
  msgs.color = imageMsg(cv::Mat(size, CV_8UC3, cv::Scalar(1, 2, 3)), enc::BGR8, 7.25);
  msgs.depth = imageMsg(cv::Mat(size, CV_16UC1, cv::Scalar(1500)), enc::TYPE_16UC1, 7.25);
  msgs.color_info = cameraInfo(10, 10, 4, 3, size.width, size.height);
  const RgbdTopics topics;
  Eigen::Isometry3d T_W_C = Eigen::Isometry3d::Identity();
  T_W_C.translation() = Eigen::Vector3d(1, 2, 3);
  T_W_C.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()).toRotationMatrix();

  RgbdFrame frame;
  ASSERT_TRUE(rgbdFrameFromMsgs(msgs, topics, T_W_C, Eigen::Isometry3d::Identity(), &frame).ok());
  EXPECT_TRUE(frame.registered);
  EXPECT_DOUBLE_EQ(frame.stamp_s, 7.25);
  EXPECT_DOUBLE_EQ(frame.K_depth.fx, 10);
  EXPECT_TRUE(frame.T_W_D.isApprox(T_W_C));
  EXPECT_EQ(frame.depth.at<uint16_t>(5, 7), 1500);

  // Unregistered: a smaller depth image with its own intrinsics and a baseline.
  const cv::Size depth_size(4, 3);
  msgs.depth = imageMsg(cv::Mat(depth_size, CV_32FC1, cv::Scalar(2.f)), enc::TYPE_32FC1, 7.25);
  msgs.depth_info = cameraInfo(5, 5, 2, 1.5, depth_size.width, depth_size.height);
  Eigen::Isometry3d T_C_D = Eigen::Isometry3d::Identity();
  T_C_D.translation() = Eigen::Vector3d(-0.025, 0, 0);
  ASSERT_TRUE(rgbdFrameFromMsgs(msgs, topics, T_W_C, T_C_D, &frame).ok());
  EXPECT_FALSE(frame.registered);
  EXPECT_DOUBLE_EQ(frame.K_depth.fx, 5);
  EXPECT_DOUBLE_EQ(frame.K_color.fx, 10);
  EXPECT_TRUE(frame.T_C_D.isApprox(T_C_D));
  EXPECT_TRUE(frame.T_W_D.isApprox(T_W_C * T_C_D));
}

TEST(RosConversionsTest, MismatchedSizesAndCameraInfoAreNamed) {
  RgbdMessages msgs;
  msgs.color = imageMsg(cv::Mat(6, 8, CV_8UC3), enc::BGR8);
  msgs.depth = imageMsg(cv::Mat(3, 4, CV_16UC1), enc::TYPE_16UC1);
  msgs.color_info = cameraInfo(10, 10, 4, 3, 8, 6);
  RgbdTopics topics;
  Status status = checkRgbdMessages(msgs, topics);
  ASSERT_FALSE(status.ok());
  EXPECT_TRUE(contains(status.message(), "8x6")) << status.message();
  EXPECT_TRUE(contains(status.message(), "4x3")) << status.message();
  EXPECT_TRUE(contains(status.message(), topics.depth)) << status.message();

  // camera_info for another resolution.
  msgs.depth = imageMsg(cv::Mat(6, 8, CV_16UC1), enc::TYPE_16UC1);
  msgs.color_info = cameraInfo(10, 10, 4, 3, 640, 480);
  status = checkRgbdMessages(msgs, topics);
  ASSERT_FALSE(status.ok());
  EXPECT_TRUE(contains(status.message(), "640x480")) << status.message();
  EXPECT_TRUE(contains(status.message(), topics.color_info)) << status.message();

  msgs.color_info = cameraInfo(10, 10, 4, 3, 8, 6);
  EXPECT_TRUE(checkRgbdMessages(msgs, topics).ok());
  msgs.depth = nullptr;
  EXPECT_FALSE(checkRgbdMessages(msgs, topics).ok());
}

// ---- Poses ------------------------------------------------------------------------------------

TEST(RosConversionsTest, PoseRoundTripAndInvalidPosesRejected) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized())).toRotationMatrix();
  T.translation() = Eigen::Vector3d(-1.5, 0.25, 2.0);
  Eigen::Isometry3d back;
  ASSERT_TRUE(poseFromMsg(poseToMsg(T), &back).ok());
  EXPECT_TRUE(back.isApprox(T, 1e-12));
  ASSERT_TRUE(transformFromMsg(transformToMsg(T), &back).ok());
  EXPECT_TRUE(back.isApprox(T, 1e-12));

  geometry_msgs::Pose nan_pose = poseToMsg(T);
  nan_pose.position.y = std::numeric_limits<double>::quiet_NaN();
  back = Eigen::Isometry3d::Identity();
  const Status nan_status = poseFromMsg(nan_pose, &back);
  EXPECT_FALSE(nan_status.ok());
  EXPECT_TRUE(contains(nan_status.message(), "NaN"));
  EXPECT_TRUE(back.isApprox(Eigen::Isometry3d::Identity()));  // untouched

  geometry_msgs::Pose zero_q = poseToMsg(T);
  zero_q.orientation.w = zero_q.orientation.x = zero_q.orientation.y = zero_q.orientation.z = 0;
  EXPECT_FALSE(poseFromMsg(zero_q, &back).ok());
  geometry_msgs::Pose long_q = poseToMsg(T);
  long_q.orientation.w *= 2.0;
  EXPECT_FALSE(poseFromMsg(long_q, &back).ok());
}

// ---- Objects ----------------------------------------------------------------------------------

TEST(RosConversionsTest, ObjectRoundTripKeepsBoxClassAndStamps) {
  MapObject object = makeObject(3, "chair", Eigen::Vector3d(1.0, -2.0, 0.45),
                                Eigen::Vector3d(0.5, 0.6, 0.9), 0.35);
  object.box_completed = true;
  const multiview_object_detection::Object msg = objectToMsg(object);
  EXPECT_TRUE(msg.box_completed);
  EXPECT_EQ(msg.id, 3);
  EXPECT_EQ(msg.class_name, "chair");
  EXPECT_EQ(msg.class_id, cocoClassId("chair"));
  EXPECT_NEAR(msg.probability, 0.87, 1e-6);
  EXPECT_EQ(msg.observations, 4);
  EXPECT_EQ(msg.num_points, 20);
  EXPECT_NEAR(msg.yaw, 0.35, 1e-6);
  EXPECT_NEAR(msg.size.z, 0.9, 1e-12);
  EXPECT_NEAR(msg.first_seen.toSec(), 10.5, 1e-6);

  MapObject back;
  ASSERT_TRUE(objectFromMsg(msg, &back).ok());
  EXPECT_EQ(back.id, object.id);
  EXPECT_EQ(back.class_id, object.class_id);
  EXPECT_EQ(back.class_name, object.class_name);
  EXPECT_NEAR(back.probability, object.probability, 1e-6);
  EXPECT_EQ(back.observations, object.observations);
  EXPECT_TRUE(back.box_completed);
  EXPECT_TRUE(back.box.center_m.isApprox(object.box.center_m, 1e-12));
  EXPECT_TRUE(back.box.size_m.isApprox(object.box.size_m, 1e-12));
  EXPECT_TRUE(back.box.rotation.isApprox(object.box.rotation, 1e-9));
  EXPECT_NEAR(back.first_seen_s, 10.5, 1e-6);
  EXPECT_NEAR(back.last_seen_s, 20.25, 1e-6);
  // The corners agree: the same box.
  const std::vector<Eigen::Vector3d> a = object.box.corners();
  const std::vector<Eigen::Vector3d> b = back.box.corners();
  for (size_t i = 0; i < a.size(); ++i) EXPECT_TRUE(a[i].isApprox(b[i], 1e-9));

  multiview_object_detection::Object bad = msg;
  bad.size.x = -1.0;
  EXPECT_FALSE(objectFromMsg(bad, &back).ok());
}

TEST(RosConversionsTest, ObjectWithBadStampsGivesZeroTimeNotAThrow) {
  MapObject object = makeObject(1, "cup", Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones(), 0);
  object.first_seen_s = -5.0;
  object.last_seen_s = std::numeric_limits<double>::quiet_NaN();
  const multiview_object_detection::Object msg = objectToMsg(object);
  EXPECT_TRUE(msg.first_seen.isZero());
  EXPECT_TRUE(msg.last_seen.isZero());
}

TEST(RosConversionsTest, ObjectArrayKeepsHeaderAndOrder) {
  const std::vector<MapObject> objects = {
      makeObject(2, "chair", Eigen::Vector3d(0, 0, 0.45), Eigen::Vector3d(0.5, 0.5, 0.9), 0),
      makeObject(7, "tv", Eigen::Vector3d(2, 0, 1.0), Eigen::Vector3d(1.0, 0.1, 0.6), 0.2)};
  const multiview_object_detection::ObjectArray array =
      objectsToMsg(objects, makeHeader("map", 3.0));
  EXPECT_EQ(array.header.frame_id, "map");
  ASSERT_EQ(array.objects.size(), 2u);
  EXPECT_EQ(array.objects[0].id, 2);
  EXPECT_EQ(array.objects[1].id, 7);
  EXPECT_EQ(array.objects[1].class_name, "tv");
}

TEST(RosConversionsTest, MarkersDrawBoxEdgesAndLabelsAndDeleteRemovedIds) {
  const Eigen::Vector3d size(0.5, 0.6, 0.9);
  std::vector<MapObject> objects = {
      makeObject(3, "chair", Eigen::Vector3d(1, 1, 0.45), size, 0.3),
      makeObject(5, "couch", Eigen::Vector3d(3, 1, 0.4), Eigen::Vector3d(2, 0.9, 0.8), 0)};
  std::set<int> published;
  visualization_msgs::MarkerArray markers =
      objectsToMarkers(objects, makeHeader("map", 1.0), &published);
  ASSERT_EQ(markers.markers.size(), 6u);
  EXPECT_EQ(published, (std::set<int>{3, 5}));

  std::map<std::string, int> per_ns;
  for (const visualization_msgs::Marker& m : markers.markers) {
    ++per_ns[m.ns];
    EXPECT_EQ(m.header.frame_id, "map");
    EXPECT_EQ(m.action, visualization_msgs::Marker::ADD);
  }
  EXPECT_EQ(per_ns["boxes"], 2);
  EXPECT_EQ(per_ns["labels"], 2);
  EXPECT_EQ(per_ns["label_lines"], 2);

  const visualization_msgs::Marker& box = markers.markers[0];
  ASSERT_EQ(box.ns, "boxes");
  EXPECT_EQ(box.id, 3);
  EXPECT_EQ(box.type, visualization_msgs::Marker::LINE_LIST);
  ASSERT_EQ(box.points.size(), 24u);  // 12 edges
  // Every edge runs along one box axis with that axis's length; 4 edges per axis.
  const Eigen::Matrix3d& R = objects[0].box.rotation;
  int per_axis[3] = {0, 0, 0};
  for (size_t i = 0; i < box.points.size(); i += 2) {
    const Eigen::Vector3d a(box.points[i].x, box.points[i].y, box.points[i].z);
    const Eigen::Vector3d b(box.points[i + 1].x, box.points[i + 1].y, box.points[i + 1].z);
    const Eigen::Vector3d d_B = R.transpose() * (b - a);
    int axis = 0;
    d_B.cwiseAbs().maxCoeff(&axis);
    EXPECT_NEAR(d_B.norm(), size[axis], 1e-9);
    EXPECT_TRUE(objects[0].box.contains(a, 1e-9));
    ++per_axis[axis];
  }
  EXPECT_EQ(per_axis[0], 4);
  EXPECT_EQ(per_axis[1], 4);
  EXPECT_EQ(per_axis[2], 4);

  const visualization_msgs::Marker& label = markers.markers[1];
  ASSERT_EQ(label.ns, "labels");
  EXPECT_EQ(label.id, 3);
  EXPECT_EQ(label.type, visualization_msgs::Marker::TEXT_VIEW_FACING);
  EXPECT_EQ(label.text, "chair #3");
  // A completed box (amodal completion) is dashed, its label as any other (issue 56: "(completed)"
  // ran over the neighbouring labels): every dash lies on one of the box's edges, and there are
  // more than 12 of them.
  std::vector<MapObject> completed = objects;
  completed[0].box_completed = true;
  const visualization_msgs::MarkerArray dashed =
      objectsToMarkers(completed, makeHeader("map", 1.0), nullptr);
  EXPECT_EQ(dashed.markers[1].text, "chair #3");
  const visualization_msgs::Marker& dashes = dashed.markers[0];
  ASSERT_EQ(dashes.ns, "boxes");
  EXPECT_GT(dashes.points.size(), 48u);
  double drawn_m = 0.0;
  for (size_t i = 0; i < dashes.points.size(); i += 2) {
    const Eigen::Vector3d a(dashes.points[i].x, dashes.points[i].y, dashes.points[i].z);
    const Eigen::Vector3d b(dashes.points[i + 1].x, dashes.points[i + 1].y, dashes.points[i + 1].z);
    EXPECT_TRUE(objects[0].box.contains(a, 1e-9));
    EXPECT_TRUE(objects[0].box.contains(b, 1e-9));
    drawn_m += (b - a).norm();
  }
  // About half of the 12 edges' length is drawn.
  const double edges_m = 4.0 * (size.x() + size.y() + size.z());
  EXPECT_GT(drawn_m, 0.4 * edges_m);
  EXPECT_LT(drawn_m, 0.65 * edges_m);
  EXPECT_GT(label.pose.position.z, 0.9);  // above the box top
  // Classes get different colours.
  const std_msgs::ColorRGBA c_chair = markers.markers[0].color;
  ASSERT_EQ(markers.markers[3].ns, "boxes");
  const std_msgs::ColorRGBA c_couch = markers.markers[3].color;
  EXPECT_GT(std::abs(c_chair.r - c_couch.r) + std::abs(c_chair.g - c_couch.g) +
                std::abs(c_chair.b - c_couch.b),
            0.1);

  // Object 3 is removed: its box and label are deleted, object 5 is re-sent.
  objects.erase(objects.begin());
  markers = objectsToMarkers(objects, makeHeader("map", 2.0), &published);
  EXPECT_EQ(published, (std::set<int>{5}));
  int deletes = 0;
  std::set<std::string> deleted_ns;
  for (const visualization_msgs::Marker& m : markers.markers) {
    if (m.action == visualization_msgs::Marker::DELETE) {
      ++deletes;
      EXPECT_EQ(m.id, 3);
      deleted_ns.insert(m.ns);
    } else {
      EXPECT_EQ(m.id, 5);
    }
  }
  EXPECT_EQ(deletes, 3);
  EXPECT_EQ(deleted_ns, (std::set<std::string>{"boxes", "labels", "label_lines"}));

  // Nothing removed since: no deletes.
  markers = objectsToMarkers(objects, makeHeader("map", 3.0), &published);
  for (const visualization_msgs::Marker& m : markers.markers) {
    EXPECT_NE(m.action, visualization_msgs::Marker::DELETE);
  }
}

// Five chairs round a table, a cup on it and a tv far away. rviz turns each label to the viewer, so
// labels whose texts could reach each other from some view must be a text height apart; each label
// stands over its own box (issue 56: labels gathered in columns stood in the sky on leader lines up
// to 2 m long), lifted only as far as its neighbours make it, and a line joins it to its box.
TEST(RosConversionsTest, LabelsStandOverTheirOwnBoxesWithoutCrossing) {
  std::vector<MapObject> objects = {makeObject(1, "dining table", Eigen::Vector3d(2, 1, 0.375),
                                               Eigen::Vector3d(1.6, 0.9, 0.75), 0.1)};
  for (int i = 0; i < 5; ++i) {
    const double angle = 2.0 * M_PI * i / 5.0;
    objects.push_back(makeObject(
        2 + i, "chair", Eigen::Vector3d(2 + 0.9 * std::cos(angle), 1 + 0.7 * std::sin(angle), 0.45),
        Eigen::Vector3d(0.45, 0.45, 0.9), angle));
  }
  objects.push_back(
      makeObject(7, "cup", Eigen::Vector3d(2.1, 1.1, 0.8), Eigen::Vector3d(0.08, 0.08, 0.1), 0));
  objects.push_back(
      makeObject(8, "tv", Eigen::Vector3d(8, 6, 1.0), Eigen::Vector3d(1.0, 0.1, 0.6), 0));
  std::map<int, visualization_msgs::Marker> labels, lines;
  for (const auto& m : objectsToMarkers(objects, makeHeader("map", 1.0), nullptr).markers) {
    if (m.ns == "labels") labels[m.id] = m;
    if (m.ns == "label_lines") lines[m.id] = m;
  }
  ASSERT_EQ(labels.size(), objects.size());
  ASSERT_EQ(lines.size(), objects.size());
  double highest_over_top_m = 0.0;
  for (const MapObject& object : objects) {
    const visualization_msgs::Marker& label = labels[object.id];
    const double top_m = object.box.center_m.z() + 0.5 * object.box.size_m.z();
    EXPECT_GT(label.pose.position.z, top_m + 0.5 * label.scale.z) << label.text;
    highest_over_top_m = std::max(highest_over_top_m, label.pose.position.z - top_m);
    // Over its own box's centre.
    EXPECT_NEAR(label.pose.position.x, object.box.center_m.x(), 1e-9) << label.text;
    EXPECT_NEAR(label.pose.position.y, object.box.center_m.y(), 1e-9) << label.text;
    // The line runs from the top of its own box, over its centre, to below its label.
    const visualization_msgs::Marker& line = lines[object.id];
    ASSERT_EQ(line.points.size(), 2u);
    EXPECT_NEAR(line.points[0].x, object.box.center_m.x(), 1e-9);
    EXPECT_NEAR(line.points[0].y, object.box.center_m.y(), 1e-9);
    EXPECT_NEAR(line.points[0].z, top_m, 1e-9);
    EXPECT_LT(line.points[1].z, label.pose.position.z);
    for (const MapObject& other : objects) {
      if (other.id <= object.id) continue;
      const visualization_msgs::Marker& b = labels[other.id];
      const double apart_m = std::hypot(label.pose.position.x - b.pose.position.x,
                                        label.pose.position.y - b.pose.position.y);
      // Half a text height per character: narrower than any font rviz draws.
      if (apart_m >= 0.25 * (label.scale.z * label.text.size() + b.scale.z * b.text.size())) {
        continue;
      }
      EXPECT_GE(std::abs(label.pose.position.z - b.pose.position.z),
                0.5 * (label.scale.z + b.scale.z))
          << "'" << label.text << "' and '" << b.text << "' cross";
    }
  }
  // Seven labels within reach of each other: at most seven lines over the lowest box top.
  EXPECT_LT(highest_over_top_m, 7 * 1.3 * labels[1].scale.z + 0.2);
  // Furniture's labels read from across the room; the cup's is smaller (issue 56: the labels of
  // the books and cups on the redkitchen's table covered each other).
  EXPECT_EQ(labels[1].text, "dining table #1");
  EXPECT_LT(labels[7].scale.z, 0.7 * labels[2].scale.z);
  EXPECT_EQ(labels[8].scale.z, labels[2].scale.z);
  // The table, first, and the tv, alone, sit just over their boxes.
  EXPECT_LT(labels[1].pose.position.z, 0.75 + 0.05 + labels[1].scale.z);
  EXPECT_LT(labels[8].pose.position.z, 1.3 + 0.05 + labels[8].scale.z);
  // A row of books along a counter, 0.6 m apart: each over its own book, none lifted more than a
  // line.
  std::vector<MapObject> row;
  for (int i = 0; i < 8; ++i) {
    row.push_back(makeObject(10 + i, "book", Eigen::Vector3d(10 + 0.6 * i, 10, 0.95),
                             Eigen::Vector3d(0.2, 0.15, 0.1), 0));
  }
  for (const auto& m : objectsToMarkers(row, makeHeader("map", 1.0), nullptr).markers) {
    if (m.ns != "labels") continue;
    EXPECT_NEAR(m.pose.position.x, 10 + 0.6 * (m.id - 10), 1e-9);
    EXPECT_LT(m.pose.position.z, 1.0 + 0.05 + 0.5 * m.scale.z + 1.3 * m.scale.z + 1e-9) << m.text;
  }
  // A newer object near the table does not move the older labels.
  std::vector<MapObject> more = objects;
  more.push_back(
      makeObject(9, "book", Eigen::Vector3d(1.9, 0.9, 0.77), Eigen::Vector3d(0.2, 0.15, 0.04), 0));
  for (const auto& m : objectsToMarkers(more, makeHeader("map", 2.0), nullptr).markers) {
    if (m.ns != "labels" || m.id == 9) continue;
    EXPECT_DOUBLE_EQ(m.pose.position.z, labels[m.id].pose.position.z) << m.text;
  }
}

TEST(RosConversionsTest, EmptyMapsAndExtremeIdsConvert) {
  // An empty map (after ~reset): a valid cloud of no points (no iterator over no data).
  sensor_msgs::PointCloud2 cloud;
  objectsToPointCloud2(std::vector<MapObject>{}, makeHeader("map", 4.0), &cloud);
  EXPECT_EQ(cloud.width * cloud.height, 0u);
  EXPECT_EQ(cloud.fields.size(), 4u);
  // Ids and classes at the ends of int get colours in [0, 1] (3 * id + 7 would overflow int).
  for (const int id : {0, 1, std::numeric_limits<int>::max(), std::numeric_limits<int>::min()}) {
    for (const std_msgs::ColorRGBA& c : {objectColor(id), classColor(id)}) {
      EXPECT_TRUE(c.r >= 0.f && c.r <= 1.f && c.g >= 0.f && c.g <= 1.f && c.b >= 0.f && c.b <= 1.f)
          << id;
    }
  }
}

TEST(RosConversionsTest, PointCloud2HoldsEveryObjectPointColouredPerObject) {
  std::vector<MapObject> objects = {
      makeObject(1, "chair", Eigen::Vector3d(1, 1, 0.45), Eigen::Vector3d(0.5, 0.6, 0.9), 0.3),
      makeObject(2, "chair", Eigen::Vector3d(3, 1, 0.45), Eigen::Vector3d(0.5, 0.6, 0.9), 0.0)};
  objects[1].segment_W.push_back(
      Eigen::Vector3f(std::numeric_limits<float>::quiet_NaN(), 0.f, 0.f));  // skipped
  sensor_msgs::PointCloud2 cloud;
  objectsToPointCloud2(objects, makeHeader("map", 4.0), &cloud);
  EXPECT_EQ(cloud.header.frame_id, "map");
  ASSERT_EQ(cloud.width * cloud.height, 40u);
  ASSERT_EQ(cloud.fields.size(), 4u);
  EXPECT_EQ(cloud.fields[3].name, "rgb");

  sensor_msgs::PointCloud2ConstIterator<float> x(cloud, "x");
  sensor_msgs::PointCloud2ConstIterator<float> y(cloud, "y");
  sensor_msgs::PointCloud2ConstIterator<float> z(cloud, "z");
  sensor_msgs::PointCloud2ConstIterator<uint8_t> rgb(cloud, "rgb");
  std::set<uint32_t> colors_first;
  std::set<uint32_t> colors_second;
  for (size_t i = 0; i < 40; ++i, ++x, ++y, ++z, ++rgb) {
    const MapObject& object = objects[i / 20];
    const Eigen::Vector3f& expected = object.segment_W[i % 20];
    EXPECT_FLOAT_EQ(*x, expected.x());
    EXPECT_FLOAT_EQ(*y, expected.y());
    EXPECT_FLOAT_EQ(*z, expected.z());
    // PCL's packing: bytes b, g, r, (pad) in memory on little-endian machines.
    const uint32_t packed =
        (static_cast<uint32_t>(rgb[2]) << 16) | (static_cast<uint32_t>(rgb[1]) << 8) | rgb[0];
    (i < 20 ? colors_first : colors_second).insert(packed);
  }
  ASSERT_EQ(colors_first.size(), 1u);
  ASSERT_EQ(colors_second.size(), 1u);
  EXPECT_NE(*colors_first.begin(), *colors_second.begin());
  EXPECT_NE(*colors_first.begin(), 0u);
}

// ---- Detections -------------------------------------------------------------------------------

TEST(RosConversionsTest, DetectionsRoundTripWithMasks) {
  const cv::Size size(64, 48);
  const std::vector<Detection2D> detections = {
      makeDetection("chair", 0.9f, cv::Rect(4, 6, 20, 30), size),
      makeDetection("cup", 0.55f, cv::Rect(40, 10, 12, 12), size)};
  const multiview_object_detection::InstanceDetections msg =
      detectionsToMsg(detections, size, makeHeader("camera", 8.0));
  ASSERT_EQ(msg.masks.size(), 2u);
  EXPECT_EQ(msg.masks[0].encoding, enc::MONO8);

  std::vector<Detection2D> back;
  std::vector<std::string> warnings;
  ASSERT_TRUE(detectionsFromMsg(msg, size, "detections", &back, &warnings).ok());
  EXPECT_TRUE(warnings.empty());
  ASSERT_EQ(back.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(back[i].class_id, detections[i].class_id);
    EXPECT_EQ(back[i].class_name, detections[i].class_name);
    EXPECT_FLOAT_EQ(back[i].score, detections[i].score);
    EXPECT_EQ(back[i].box_px, detections[i].box_px);
    // Box-sized masks (a detection costs its box, not the image), the same pixels.
    ASSERT_EQ(back[i].mask.size(), detections[i].box_px.size());
    const cv::Rect image_rect(cv::Point(0, 0), size);
    EXPECT_EQ(cv::countNonZero(maskInRegion(back[i], size, image_rect) != detections[i].mask), 0);
  }
  // And back into a message: image-sized masks again.
  const multiview_object_detection::InstanceDetections again =
      detectionsToMsg(back, size, makeHeader("camera", 8.0));
  ASSERT_EQ(again.masks.size(), 2u);
  EXPECT_EQ(again.masks[0].data, msg.masks[0].data);
  EXPECT_EQ(again.masks[1].data, msg.masks[1].data);
}

TEST(RosConversionsTest, ScoresOutsideZeroOneAreDroppedAndLargeMessagesCapped) {
  const cv::Size size(64, 48);
  multiview_object_detection::InstanceDetections msg;
  msg.header = makeHeader("camera", 8.0);
  // 2000 boxes covering the whole image (what a hostile or broken detector may send), with a
  // percentage score and an absurd one among them.
  for (int i = 0; i < 2000; ++i) {
    sensor_msgs::RegionOfInterest roi;
    roi.width = 64;
    roi.height = 48;
    msg.boxes.push_back(roi);
    msg.class_ids.push_back(cocoClassId("chair"));
    msg.scores.push_back(0.5f + 0.4f * static_cast<float>(i % 1000) / 1000.f);
  }
  msg.scores[3] = 5.f;
  msg.scores[4] = 1e30f;
  msg.scores[5] = -0.1f;
  std::vector<Detection2D> detections;
  std::vector<std::string> warnings;
  size_t capped = 0;
  ASSERT_TRUE(
      detectionsFromMsg(msg, size, "detections", &detections, &warnings, 100, &capped).ok());
  ASSERT_EQ(detections.size(), 100u);
  EXPECT_EQ(capped, 1997u - 100u);
  for (const Detection2D& d : detections) {
    EXPECT_GE(d.score, 0.5f + 0.4f * 949.f / 1000.f);  // the highest-scoring
    EXPECT_LE(d.score, 1.f);
    EXPECT_EQ(d.mask.size(), d.box_px.size());
  }
  int score_warnings = 0;
  int cap_warnings = 0;
  for (const std::string& warning : warnings) {
    if (contains(warning, "not a probability")) ++score_warnings;
    if (contains(warning, "max_detections_per_frame")) ++cap_warnings;
  }
  EXPECT_EQ(score_warnings, 3);
  EXPECT_EQ(cap_warnings, 1);
}

TEST(RosConversionsTest, DetectionsWithoutMasksUseTheBoxAndNamesDecideUnknownIds) {
  const cv::Size size(64, 48);
  multiview_object_detection::InstanceDetections msg;
  msg.header = makeHeader("camera", 8.0);
  sensor_msgs::RegionOfInterest roi;
  roi.x_offset = 10;
  roi.y_offset = 5;
  roi.width = 20;
  roi.height = 10;
  msg.boxes = {roi, roi};
  msg.class_ids = {-1, -1};
  msg.class_names = {"chair", "unicorn"};
  msg.scores = {0.8f, 0.7f};
  std::vector<Detection2D> detections;
  ASSERT_TRUE(detectionsFromMsg(msg, size, "detections", &detections).ok());
  ASSERT_EQ(detections.size(), 2u);
  EXPECT_EQ(detections[0].class_id, cocoClassId("chair"));
  EXPECT_EQ(detections[1].class_id, -1);  // the mapper reports it as an unknown class
  EXPECT_EQ(detections[1].class_name, "unicorn");
  EXPECT_EQ(detections[0].mask.size(), cv::Size(20, 10));  // box-sized
  EXPECT_EQ(cv::countNonZero(detections[0].mask), 200);

  // A class id wins over a differing name.
  msg.class_ids = {cocoClassId("tv"), -1};
  ASSERT_TRUE(detectionsFromMsg(msg, size, "detections", &detections).ok());
  EXPECT_EQ(detections[0].class_name, "tv");

  // A box reaching past the border is clipped; one entirely outside is dropped with a warning.
  msg.boxes[0].x_offset = 50;
  msg.boxes[1].x_offset = 100;
  std::vector<std::string> warnings;
  ASSERT_TRUE(detectionsFromMsg(msg, size, "detections", &detections, &warnings).ok());
  ASSERT_EQ(detections.size(), 1u);
  EXPECT_EQ(detections[0].box_px, cv::Rect(50, 5, 14, 10));
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_TRUE(contains(warnings[0], "detection 1"));
}

TEST(RosConversionsTest, DetectionsWithInconsistentArraysOrMasksAreRefused) {
  const cv::Size size(64, 48);
  multiview_object_detection::InstanceDetections msg =
      detectionsToMsg({makeDetection("chair", 0.9f, cv::Rect(4, 6, 20, 30), size),
                       makeDetection("cup", 0.6f, cv::Rect(40, 10, 12, 12), size)},
                      size, makeHeader("camera", 8.0));
  std::vector<Detection2D> detections(1);

  multiview_object_detection::InstanceDetections bad = msg;
  bad.scores.pop_back();
  Status status = detectionsFromMsg(bad, size, "detections", &detections);
  ASSERT_FALSE(status.ok());
  EXPECT_TRUE(contains(status.message(), "scores"));
  EXPECT_TRUE(contains(status.message(), "detections"));
  EXPECT_EQ(detections.size(), 1u);  // untouched

  bad = msg;
  bad.masks.pop_back();
  EXPECT_FALSE(detectionsFromMsg(bad, size, "detections", &detections).ok());

  // A mask of another size or encoding costs only that detection.
  bad = msg;
  bad.masks[0].width = 32;
  bad.masks[1].encoding = enc::BGR8;
  std::vector<std::string> warnings;
  ASSERT_TRUE(detectionsFromMsg(bad, size, "detections", &detections, &warnings).ok());
  EXPECT_TRUE(detections.empty());
  EXPECT_EQ(warnings.size(), 2u);

  bad = msg;
  bad.masks[0].data.resize(10);  // truncated
  warnings.clear();
  ASSERT_TRUE(detectionsFromMsg(bad, size, "detections", &detections, &warnings).ok());
  EXPECT_EQ(detections.size(), 1u);
  EXPECT_EQ(warnings.size(), 1u);
}

// ---- Node configuration -------------------------------------------------------------------------

TEST(RosConversionsTest, NodeConfigValidatesChoicesAndDerivesGravity) {
  ObjectDetectionRosConfig config;
  EXPECT_TRUE(config.isValid().ok()) << config.isValid().message();
  EXPECT_TRUE(config.mapperConfig().gravity_down_W.isApprox(Eigen::Vector3d(0, 0, -1)));

  config.gravity_down_W = Eigen::Vector3d(0, -2, 0);
  EXPECT_TRUE(config.mapperConfig().gravity_down_W.isApprox(Eigen::Vector3d(0, -1, 0)));
  config.gravity_source = "estimate";
  EXPECT_TRUE(config.mapperConfig().gravity_down_W.isZero());
  config.gravity_source = "param";
  config.gravity_down_W = Eigen::Vector3d::Zero();
  EXPECT_FALSE(config.isValid().ok());

  config = ObjectDetectionRosConfig();
  config.autosave_period_s = 0.5;  // a save every half second is no longer a background task
  EXPECT_TRUE(contains(config.isValid().message(), "autosave_period_s"));
  config.autosave_period_s = 0.0;  // off
  EXPECT_TRUE(config.isValid().ok());
  EXPECT_EQ(defaultAutosaveName("/robot1/object_detection"),
            "robot1.object_detection.autosave.mvmap");
  EXPECT_EQ(defaultAutosaveName("/"), "object_detection.autosave.mvmap");

  config = ObjectDetectionRosConfig();
  config.pose_source = "gps";
  EXPECT_TRUE(contains(config.isValid().message(), "gps"));
  config = ObjectDetectionRosConfig();
  config.detector = "yolo";
  EXPECT_TRUE(contains(config.isValid().message(), "yolo"));
  config = ObjectDetectionRosConfig();
  config.detector = "topic";
  EXPECT_TRUE(config.isValid().ok());
  config.processing_queue_size = 0;
  EXPECT_FALSE(config.isValid().ok());
  config = ObjectDetectionRosConfig();
  config.mapper.lccp.seed_resolution_m = 0.001;  // below the voxel resolution
  EXPECT_TRUE(contains(config.isValid().message(), "lccp")) << config.isValid().message();
  config = ObjectDetectionRosConfig();
  config.keyframes.every_n = 0;
  EXPECT_FALSE(config.isValid().ok());
  EXPECT_TRUE(contains(config.print(), "keyframe_every_n: 0"));
}

// Issue 34's values, typed as a user might: each is refused naming the parameter (they were
// accepted, or hung the worker).
TEST(RosConversionsTest, ValuesThatWouldStallTheWorkerAreRefusedNamingTheParameter) {
  const auto refused = [](const std::function<void(ObjectDetectionRosConfig*)>& set,
                          const std::string& name) {
    ObjectDetectionRosConfig config;
    set(&config);
    const Status status = config.isValid();
    EXPECT_FALSE(status.ok()) << name;
    EXPECT_TRUE(contains(status.message(), name)) << status.message();
  };
  refused([](ObjectDetectionRosConfig* c) { c->mapper.gravity.ransac_iterations = 2000000000; },
          "gravity/ransac_iterations");
  refused([](ObjectDetectionRosConfig* c) { c->mapper.lccp.voxel_resolution_m = 1e-5; },
          "lccp/voxel_resolution_m");
  refused([](ObjectDetectionRosConfig* c) { c->mapper.lccp.seed_resolution_m = 1e-5; },
          "lccp/seed_resolution_m");
  refused([](ObjectDetectionRosConfig* c) { c->mapper.filter.voxel_leaf_size_m = 1e-9; },
          "filter/voxel_leaf_size_m");
  refused([](ObjectDetectionRosConfig* c) { c->mapper.database.fusion_voxel_size_m = 1e-6; },
          "database/fusion_voxel_size_m");
  refused([](ObjectDetectionRosConfig* c) { c->mapper.box.outline_cell_m = 1e-7; },
          "box/outline_cell_m");
  refused([](ObjectDetectionRosConfig* c) { c->mapper.filter.sor_mean_k = 100000000; },
          "filter/sor_mean_k");
  refused([](ObjectDetectionRosConfig* c) { c->gravity_down_W = Eigen::Vector3d(1e308, 1e308, 0); },
          "gravity_down");
  refused([](ObjectDetectionRosConfig* c) { c->detections_max_age_s = 1e300; },
          "detections_max_age_s");
  refused([](ObjectDetectionRosConfig* c) { c->queue_size = 2147483647; }, "queue_size");
  refused([](ObjectDetectionRosConfig* c) { c->processing_queue_size = 2147483647; },
          "processing_queue_size");
  refused([](ObjectDetectionRosConfig* c) { c->processing_queue_max_mb = 0.0; },
          "processing_queue_max_mb");
  refused([](ObjectDetectionRosConfig* c) { c->processing_queue_max_mb = std::nan(""); },
          "processing_queue_max_mb");
  ObjectDetectionRosConfig off;
  off.mapper.box.outline_cell_m = 0.0;  // 0 switches the outline normals off
  EXPECT_TRUE(off.isValid().ok()) << off.isValid().message();
}

// dynamic_reconfigure's limits (cfg/ObjectDetection.cfg; names with '/' as '_') are the table's.
TEST(RosConversionsTest, DynamicReconfigureLimitsAreTheTablesRanges) {
  using multiview_object_detection::ObjectDetectionConfig;
  const auto number = [](const boost::any& value) {
    if (value.type() == typeid(int)) return static_cast<double>(boost::any_cast<int>(value));
    if (value.type() == typeid(double)) return boost::any_cast<double>(value);
    return std::nan("");
  };
  int compared = 0;
  for (const ParameterRange& range : parameterRanges()) {
    std::string name = range.name;
    std::replace(name.begin(), name.end(), '/', '_');
    for (const auto& description : ObjectDetectionConfig::__getParamDescriptions__()) {
      if (description->name != name) continue;
      boost::any min_value, max_value;
      description->getValue(ObjectDetectionConfig::__getMin__(), min_value);
      description->getValue(ObjectDetectionConfig::__getMax__(), max_value);
      EXPECT_DOUBLE_EQ(number(min_value), range.min) << name;
      EXPECT_DOUBLE_EQ(number(max_value), range.max) << name;
      ++compared;
    }
  }
  EXPECT_GE(compared, 3);  // keyframe_every_n, fusion voxel size, refine_every_n_keyframes
}

// One name per setting: every dynamic_reconfigure parameter has a YAML name in the node's config
// file (its own name, or the nested name the .cfg writes with '_').
TEST(RosConversionsTest, EveryReconfigureNameHasItsYamlNameInTheConfigFile) {
  using multiview_object_detection::ObjectDetectionConfig;
  // Down the nested maps to a value (const access: a missing key gives an undefined node).
  std::function<bool(const YAML::Node&, const std::string&)> hasScalar;
  hasScalar = [&hasScalar](const YAML::Node& node, const std::string& path) {
    const std::string::size_type slash = path.find('/');
    const YAML::Node child = node[path.substr(0, slash)];
    if (!child) return false;
    if (slash == std::string::npos) return child.IsScalar();
    return child.IsMap() && hasScalar(child, path.substr(slash + 1));
  };
  // The settings paper_method changes are commented out there ("# enable: true  # default ..."):
  // uncommented for the look-up.
  std::ifstream file(std::string(MVOD_SOURCE_DIR) + "/config/object_detection.yaml");
  ASSERT_TRUE(file.good());
  const std::string text((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  const YAML::Node yaml = YAML::Load(
      std::regex_replace(text, std::regex("^( *)# ([a-z_]+: )", std::regex::multiline), "$1$2"));
  int nested = 0;
  for (const auto& description : ObjectDetectionConfig::__getParamDescriptions__()) {
    const std::string yaml_name = yamlParameterName(description->name);
    if (yaml_name != description->name) ++nested;
    EXPECT_TRUE(hasScalar(yaml, yaml_name))
        << description->name << " -> " << yaml_name
        << " is not a parameter of config/object_detection.yaml";
  }
  EXPECT_EQ(nested, 10);
}

// Dead and slow inputs: an input silent for timeout_s (or since the start) is an error naming it, a
// slow one a warning, a steady one ok with its rate; unexpected topics are not tracked.
// The cases: 74 of 74 frames rejected (mono8 colour) and 91 of 92 pose lookups failed
// (no TF) left /diagnostics at "ok".
// Frames lost before the node (issue 55, item 5): a 30 Hz stream that reaches the node with gaps.
TEST(FrameGapsTest, CountsMissingSequenceNumbersOrStampsAndNothingInASteadyStream) {
  const double period = 1.0 / 30.0;
  {  // numbered (a driver, rosbag play): 100 frames, every 4th lost
    FrameGaps gaps;
    int reached = 0;
    for (std::uint32_t seq = 1; seq <= 100; ++seq) {
      if (seq % 4 == 0) continue;
      gaps.add(seq, 10.0 + seq * period);
      ++reached;
    }
    EXPECT_EQ(gaps.lost(), 24);  // 25 multiples of 4, the last (100) after the last received
    EXPECT_EQ(gaps.received(), reached);
  }
  {  // unnumbered (seq 0 throughout): the stamps, with 2 ms jitter; 3 frames lost at once, twice
    FrameGaps gaps;
    int missing = 0;
    for (int k = 0; k < 60; ++k) {
      if ((k >= 20 && k < 23) || (k >= 40 && k < 43)) continue;
      missing += gaps.add(0, 5.0 + k * period + ((k % 3) - 1) * 0.002);
    }
    EXPECT_EQ(missing, 6);
    EXPECT_EQ(gaps.lost(), 6);
  }
  {  // a steady stream of every 5th frame (a subsampled bag): no loss
    FrameGaps gaps;
    for (int k = 0; k < 50; ++k) gaps.add(0, 1.0 + k * 5 * period);
    for (int k = 0; k < 50; ++k) gaps.add(7 + static_cast<std::uint32_t>(k), 20.0 + k * 5 * period);
    EXPECT_EQ(gaps.lost(), 0);
  }
  {  // numbered without gaps, but the stamps skip 2 frames (a driver that never sent them)
    FrameGaps gaps;
    for (std::uint32_t seq = 1; seq <= 30; ++seq)
      gaps.add(seq, (seq > 20 ? 2 : 0) * period + seq * period);
    EXPECT_EQ(gaps.lost(), 2);
  }
  {  // irregular stamps (a bag of keyframes only): not judged
    FrameGaps gaps;
    const double steps[] = {0.2, 0.9, 0.3, 1.7, 0.25, 0.6, 2.4, 0.4, 0.35, 1.1};
    double t = 1.0;
    for (int k = 0; k < 40; ++k) gaps.add(0, t += steps[k % 10]);
    EXPECT_EQ(gaps.lost(), 0);
  }
  {  // a bag played again (stamps and numbers start over) and a restarted driver: no loss counted
    FrameGaps gaps;
    for (std::uint32_t seq = 1; seq <= 20; ++seq) gaps.add(seq, 1.0 + seq * period);
    for (std::uint32_t seq = 1; seq <= 20; ++seq) gaps.add(seq, 1.0 + seq * period);
    for (std::uint32_t seq = 500000; seq <= 500020; ++seq) gaps.add(seq, 3.0 + seq * 1e-6);
    EXPECT_EQ(gaps.lost(), 0);
  }
}

// A SLAM's TF stamped when it is published (ethz-asl/orb_slam_2_ros) instead of with its image's
// stamp (issue 55, item 1): a 30 Hz camera, one pose per image, tracked in 35 ms.
TEST(TfStampCheckTest, ATfStampedWhenPublishedIsNamedAndImageStampsOrOtherSourcesAreNot) {
  const double period = 1.0 / 30.0;
  const double tracking_s = 0.035;
  // `stamp(k)`: the stamp of the pose of image k; `received(k)`: when it reaches the node.
  auto run = [&](const std::string& parent, int images, const std::function<double(int)>& stamp,
                 const std::function<double(int)>& received) {
    TfStampCheck check("map");
    for (int k = 0; k < images; ++k) {
      check.addImage(100.0 + k * period);
      check.addTransform(parent, "camera_link", stamp(k), received(k));
    }
    return check.problem();
  };
  auto image = [&](int k) { return 100.0 + k * period; };
  auto tracked = [&](int k) { return image(k) + tracking_s + 0.001; };
  // appliedAI's wrapper: the image's stamp, arriving after tracking.
  EXPECT_EQ(run("map", 200, image, tracked), "");
  // ethz-asl's: stamped at publishing, arriving 1 ms later.
  const std::string problem = run(
      "map", 200, [&](int k) { return image(k) + tracking_s; }, tracked);
  EXPECT_NE(problem.find("TF 'map' -> 'camera_link' looks stamped when it was published"),
            std::string::npos)
      << problem;
  EXPECT_NE(problem.find("none of its last 50 transforms"), std::string::npos) << problem;
  EXPECT_NE(problem.find("ethz-asl/orb_slam_2_ros"), std::string::npos) << problem;
  // Too few transforms to judge yet.
  EXPECT_EQ(run(
                "map", 40, [&](int k) { return image(k) + tracking_s; }, tracked),
            "");
  // tf1-style frame names.
  EXPECT_NE(run(
                "/map", 200, [&](int k) { return image(k) + tracking_s; }, tracked),
            "");
  // Another sensor's pose (a laser SLAM at 10 Hz): its own stamps, a scan period and more old when
  // they arrive: not judged published.
  EXPECT_EQ(run(
                "map", 200, [&](int k) { return image(k) + 0.013; },
                [&](int k) { return image(k) + 0.133; }),
            "");
  // A bag of keyframes (one image in 20) with a pose at every frame, stamped as it was recorded:
  // too few images among the transforms to judge.
  {
    TfStampCheck check("map");
    for (int k = 0; k < 400; ++k) {
      if (k % 20 == 0) check.addImage(image(k));
      check.addTransform("map", "camera_link", image(k) + 0.004, image(k) + 0.004);
    }
    EXPECT_EQ(check.problem(), "");
  }
  // Not out of the world frame (odometry): not watched.
  EXPECT_EQ(run(
                "odom", 200, [&](int k) { return image(k) + tracking_s; }, tracked),
            "");
  // One transform in the window at an image's stamp is enough to say nothing.
  EXPECT_EQ(
      run(
          "map", 200, [&](int k) { return k == 190 ? image(k) : image(k) + tracking_s; }, tracked),
      "");
}

TEST(RejectionWindowTest, RejectedInputIsAWarningAndMostlyRejectedAnError) {
  RejectionWindow window(10.0);
  EXPECT_EQ(window.report("", "").level, RejectionWindow::kOk);  // nothing yet
  // 30 good frames a second for 3 s.
  for (int s = 0; s <= 3; ++s) window.add(s, {30L * s, 0, 0});
  EXPECT_EQ(window.report("", "").level, RejectionWindow::kOk);
  // One rejected frame among them: a warning naming the reason.
  window.add(4.0, {120, 1, 0});
  RejectionWindow::Report report = window.report("wrong encoding 'mono8'", "");
  EXPECT_EQ(report.level, RejectionWindow::kWarn);
  EXPECT_NE(report.message.find("1 of 120 frames rejected"), std::string::npos) << report.message;
  EXPECT_NE(report.message.find("mono8"), std::string::npos) << report.message;

  // Every frame rejected from then on: an error once the rejected are at least half.
  RejectionWindow all(10.0);
  all.add(0.0, {0, 0, 0});
  all.add(1.0, {15, 15, 0});
  report = all.report("wrong encoding 'mono8'", "");
  EXPECT_EQ(report.level, RejectionWindow::kError);
  EXPECT_NE(report.message.find("15 of 15 frames rejected"), std::string::npos) << report.message;
  // Two rejected frames are a warning, not yet an error.
  RejectionWindow two(10.0);
  two.add(0.0, {0, 0, 0});
  two.add(1.0, {2, 2, 0});
  EXPECT_EQ(two.report("", "").level, RejectionWindow::kWarn);

  // 91 of 92 camera poses failed (pose_source tf without TF).
  RejectionWindow poses(10.0);
  poses.add(0.0, {0, 0, 0});
  poses.add(5.0, {92, 0, 91});
  report = poses.report("", "no transform 'map' <- 'camera_rgb_optical_frame'");
  EXPECT_EQ(report.level, RejectionWindow::kError);
  EXPECT_NE(report.message.find("91 of 92 camera poses failed"), std::string::npos)
      << report.message;
  EXPECT_NE(report.message.find("camera_rgb_optical_frame"), std::string::npos) << report.message;

  // The window moves on: good frames for longer than it, and the status is ok again.
  for (int s = 6; s <= 20; ++s) poses.add(s, {92L + 30L * (s - 5), 0, 91});
  EXPECT_EQ(poses.report("", "").level, RejectionWindow::kOk) << poses.report("", "").message;
}

// The start-up line names only the settings that differ from the defaults (issue 47: about 200
// lines of configuration at every start).
TEST(RosConversionsTest, ConfigPrintChangesListsOnlyWhatDiffersFromTheDefaults) {
  const ObjectDetectionRosConfig defaults;
  EXPECT_EQ(defaults.printChanges(defaults), "");
  ObjectDetectionRosConfig config;
  config.world_frame = "odom";
  config.processing_queue_size = 5;
  const std::string changes = config.printChanges(defaults);
  EXPECT_EQ(changes, "processing_queue_size 5, world_frame odom");
  // gravity_down once, under the parameter's name (the mapper's copy of it is not printed again).
  config.gravity_down_W = Eigen::Vector3d(0.0, -1.0, 0.0);
  EXPECT_EQ(config.printChanges(defaults),
            "gravity_down [0, -1, 0], processing_queue_size 5, world_frame odom");
  const std::string all = config.print();
  EXPECT_GT(std::count(all.begin(), all.end(), '\n'), 50);
}

TEST(InputMonitorTest, SilentInputsAreErrorsSlowOnesWarningsAndTheyRecover) {
  using Clock = InputMonitor::Clock;
  const Clock::time_point t0 = Clock::now();
  const auto at = [t0](double s) {
    return t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
  };
  InputMonitor monitor;
  monitor.configure({/*min_rate_hz=*/2.0, /*timeout_s=*/3.0}, t0);
  monitor.expect("/camera/rgb/image_rect_color", true);
  monitor.expect("/detections", false);
  monitor.received("/not/expected", at(0.1));

  std::vector<InputMonitor::Report> reports = monitor.reports(at(1.0));
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_EQ(reports[0].level, InputMonitor::kOk) << reports[0].message;  // waiting, not yet late
  reports = monitor.reports(at(3.5));
  EXPECT_EQ(reports[0].level, InputMonitor::kError);
  EXPECT_NE(reports[0].message.find("/camera/rgb/image_rect_color"), std::string::npos);
  EXPECT_NE(reports[0].message.find("remapped"), std::string::npos) << reports[0].message;
  EXPECT_EQ(reports[1].level, InputMonitor::kError);

  // 10 Hz from 4 s to 10 s: ok, about 10 Hz.
  for (int i = 0; i < 60; ++i) monitor.received("/camera/rgb/image_rect_color", at(4.0 + 0.1 * i));
  for (double t = 4.0; t < 10.0; t += 2.0) monitor.received("/detections", at(t));
  reports = monitor.reports(at(10.0));
  EXPECT_EQ(reports[0].level, InputMonitor::kOk) << reports[0].message;
  EXPECT_NEAR(reports[0].rate_hz, 10.0, 0.5);
  EXPECT_EQ(reports[0].messages, 60);
  EXPECT_EQ(reports[1].level, InputMonitor::kOk) << reports[1].message;  // 0.5 Hz: no rate check

  // 1 Hz: slower than 2 Hz, a warning.
  for (double t = 10.0; t < 16.0; t += 1.0) monitor.received("/camera/rgb/image_rect_color", at(t));
  reports = monitor.reports(at(16.0));
  EXPECT_EQ(reports[0].level, InputMonitor::kWarn) << reports[0].message;
  EXPECT_NE(reports[0].message.find("below input_min_rate_hz"), std::string::npos);

  // Silent for 3 s: an error again, naming how long.
  reports = monitor.reports(at(19.5));
  EXPECT_EQ(reports[0].level, InputMonitor::kError) << reports[0].message;
  EXPECT_NEAR(reports[0].silent_s, 4.5, 1e-6);
  EXPECT_NE(reports[0].message.find("nothing on"), std::string::npos) << reports[0].message;
}

// On a bag's clock (use_sim_time; issue 56, first hour): make demo's roslaunch.log ended in red
// "nothing on '...' for 5 s" once its bag had ended, and a node waiting for a bag said its inputs
// were wrongly remapped. Silence the stopped clock explains is OK and says so; before any /clock,
// a WARN asks for the bag; an input that stopped while the clock ran is still an ERROR.
TEST(InputMonitorTest, OnABagsClockSilenceThatTheStoppedClockExplainsIsNoError) {
  using Clock = InputMonitor::Clock;
  const Clock::time_point t0 = Clock::now();
  const auto at = [t0](double s) {
    return t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
  };
  InputMonitor monitor;
  monitor.configure({/*min_rate_hz=*/1.0, /*timeout_s=*/5.0}, t0);
  monitor.expect("/camera/rgb/image_rect_color", true);
  monitor.expect("/detections", false);
  InputMonitor::ClockState clock;
  clock.sim_time = true;
  // No /clock in 8 s: a warning asking for the bag, not a remap error.
  clock.still_s = 8.0;
  std::vector<InputMonitor::Report> reports = monitor.reports(at(8.0), clock);
  EXPECT_EQ(reports[0].level, InputMonitor::kWarn) << reports[0].message;
  EXPECT_NE(reports[0].message.find("no /clock came in 8 s"), std::string::npos)
      << reports[0].message;
  // The bag plays from 8 s to 20 s (10 Hz images; detections until 12 s only), then ends: the
  // clock stops at 20 s.
  clock.started = true;
  for (int i = 0; i < 120; ++i) monitor.received("/camera/rgb/image_rect_color", at(8.0 + 0.1 * i));
  monitor.received("/detections", at(12.0));
  clock.still_s = 7.0;  // at 27 s
  reports = monitor.reports(at(27.0), clock);
  EXPECT_EQ(reports[0].level, InputMonitor::kOk) << reports[0].message;
  EXPECT_NE(reports[0].message.find("the clock stopped 7 s ago (a bag paused or ended)"),
            std::string::npos)
      << reports[0].message;
  // The detections stopped 8 s before the clock did: still an error.
  EXPECT_EQ(reports[1].level, InputMonitor::kError) << reports[1].message;
  // The clock running: the same silence is an error.
  clock.still_s = 0.0;
  reports = monitor.reports(at(27.0), clock);
  EXPECT_EQ(reports[0].level, InputMonitor::kError) << reports[0].message;
  // On the wall clock nothing changes.
  clock.sim_time = false;
  clock.still_s = 7.0;
  EXPECT_EQ(monitor.reports(at(27.0), clock)[0].level, InputMonitor::kError);
}

// A service handler that throws (a disk error in ~save_map, a bad_alloc in ~refine) is answered,
// not left to roscpp: success false with the exception's text where the response has a message;
// ~get_objects, which has none, fails the call. A handler that returns is passed through.
TEST(ServiceAnsweringTest, AnExceptionIsAnsweredWithItsText) {
  using multiview_object_detection::GetObjects;
  using multiview_object_detection::MapFile;
  using Trigger = std_srvs::Trigger;
  const boost::function<bool(MapFile::Request&, MapFile::Response&)> save_map =
      [](MapFile::Request&, MapFile::Response&) -> bool { throw std::runtime_error("disk gone"); };
  MapFile::Request map_request;
  MapFile::Response map_response;
  map_response.success = true;
  EXPECT_TRUE(answering("save_map", save_map)(map_request, map_response));
  EXPECT_FALSE(map_response.success);
  EXPECT_EQ(map_response.message, "save_map failed: disk gone");

  const boost::function<bool(Trigger::Request&, Trigger::Response&)> refine =
      [](Trigger::Request&, Trigger::Response&) -> bool { throw std::bad_alloc(); };
  Trigger::Request trigger_request;
  Trigger::Response trigger_response;
  trigger_response.success = true;
  EXPECT_TRUE(answering("refine", refine)(trigger_request, trigger_response));
  EXPECT_FALSE(trigger_response.success);
  EXPECT_EQ(trigger_response.message.rfind("refine failed: ", 0), 0u) << trigger_response.message;

  const boost::function<bool(GetObjects::Request&, GetObjects::Response&)> get_objects =
      [](GetObjects::Request&, GetObjects::Response&) -> bool {
    throw std::runtime_error("snapshot gone");
  };
  GetObjects::Request objects_request;
  GetObjects::Response objects_response;
  EXPECT_FALSE(answering("get_objects", get_objects)(objects_request, objects_response));

  const boost::function<bool(Trigger::Request&, Trigger::Response&)> fine =
      [](Trigger::Request&, Trigger::Response& response) {
        response.success = true;
        response.message = "refined";
        return true;
      };
  EXPECT_TRUE(answering("refine", fine)(trigger_request, trigger_response));
  EXPECT_TRUE(trigger_response.success);
  EXPECT_EQ(trigger_response.message, "refined");
}

}  // namespace mvod

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
