// Helpers shared by the node's rostests and the rviz test's publisher: a synthetic RGB-D stream
// published on the node's inputs the way a Kinect, ORB-SLAM2 and a detector host would, and
// collectors of the node's outputs.
#pragma once

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <gtest/gtest.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_ros/transform_broadcaster.h>
#include <unistd.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "multiview_object_detection/GetObjects.h"
#include "multiview_object_detection/InstanceDetections.h"
#include "multiview_object_detection/MapFile.h"
#include "multiview_object_detection/ObjectArray.h"
#include "multiview_object_detection/pipeline/types/class_priors.h"
#include "multiview_object_detection/simulation/synthetic_scene.h"

namespace mvod_test {

// Absolute input topics of the tests; the .test files remap the node's relative inputs onto them.
constexpr char kRgbTopic[] = "/camera/rgb/image_rect_color";
constexpr char kDepthTopic[] = "/camera/depth_registered/image_rect";
constexpr char kInfoTopic[] = "/camera/rgb/camera_info";
constexpr char kPoseTopic[] = "/slam/pose";
constexpr char kDetectionsTopic[] = "/detector/detections";
constexpr char kWorldFrame[] = "map";
// The node's default output frame (config/object_detection.yaml): z up, on the floor.
constexpr char kOutputFrame[] = "map_gravity_aligned";
constexpr char kCameraFrame[] = "camera_rgb_optical_frame";

// ros::service::call, tried once more when the call got no answer at all (the master's lookup or
// the connection failed, as happened once in CI on a loaded machine), once the service is
// advertised again (up to 30 s). What the node answers, refusals included, is returned as it is. A
// retry is printed, with whether the service was advertised when the call failed.
template <typename Service>
bool callService(const std::string& name, Service& srv) {
  if (ros::service::call(name, srv)) return true;
  std::printf("[callService] %s got no answer (advertised: %s); trying once more\n", name.c_str(),
              ros::service::exists(name, false) ? "yes" : "no");
  std::fflush(stdout);
  return ros::service::waitForService(name, ros::Duration(30.0)) && ros::service::call(name, srv);
}

inline geometry_msgs::Pose toPoseMsg(const Eigen::Isometry3d& T) {
  geometry_msgs::Pose pose;
  pose.position.x = T.translation().x();
  pose.position.y = T.translation().y();
  pose.position.z = T.translation().z();
  const Eigen::Quaterniond q(T.linear());
  pose.orientation.x = q.x();
  pose.orientation.y = q.y();
  pose.orientation.z = q.z();
  pose.orientation.w = q.w();
  return pose;
}

inline Eigen::Isometry3d fromPoseMsg(const geometry_msgs::Pose& pose) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z);
  T.linear() = Eigen::Quaterniond(pose.orientation.w, pose.orientation.x, pose.orientation.y,
                                  pose.orientation.z)
                   .normalized()
                   .toRotationMatrix();
  return T;
}

inline sensor_msgs::Image toImageMsg(const cv::Mat& image, const std::string& encoding,
                                     const std_msgs::Header& header) {
  sensor_msgs::Image msg;
  msg.header = header;
  msg.height = static_cast<uint32_t>(image.rows);
  msg.width = static_cast<uint32_t>(image.cols);
  msg.encoding = encoding;
  msg.is_bigendian = 0;
  msg.step = static_cast<uint32_t>(image.cols * image.elemSize());
  msg.data.resize(static_cast<size_t>(msg.step) * image.rows);
  for (int v = 0; v < image.rows; ++v) {
    std::memcpy(&msg.data[static_cast<size_t>(v) * msg.step], image.ptr(v), msg.step);
  }
  return msg;
}

// One synthetic frame as the node's inputs.
struct FrameMsgs {
  int index = 0;
  sensor_msgs::Image rgb;
  sensor_msgs::Image depth;
  sensor_msgs::CameraInfo info;
  geometry_msgs::PoseStamped pose;  // camera optical frame in the world
  multiview_object_detection::InstanceDetections detections;
};

// SyntheticScene's camera loop at a reduced resolution (fast enough for a 2-core test machine).
class SyntheticStream {
 public:
  struct Options {
    int num_frames = 12;  // frames per lap: 30 degrees apart, so every frame is a motion keyframe
    int width = 320;
    int height = 240;
    int min_mask_pixels = 50;
    // Object index -> class name to report instead of the true one (e.g. an atypical object).
    std::map<int, std::string> relabel;
    // The room changed: object index -> its move (world frame), and the objects taken away.
    std::map<int, Eigen::Vector3d> moved;
    std::set<int> removed;
  };

  explicit SyntheticStream(const Options& options)
      : options_(options), scene_(changedScene(options)) {}

  const mvod::SyntheticScene& scene() const { return scene_; }
  const Options& options() const { return options_; }

  FrameMsgs make(int index, const ros::Time& stamp) const {
    mvod::RgbdFrame frame;
    cv::Mat labels;
    scene_.render(index, &frame, &labels);
    FrameMsgs msgs;
    msgs.index = index;
    std_msgs::Header header;
    header.stamp = stamp;
    header.frame_id = kCameraFrame;
    msgs.rgb = toImageMsg(frame.color_bgr, "bgr8", header);
    msgs.depth = toImageMsg(frame.depth, "16UC1", header);

    const mvod::CameraIntrinsics& K = scene_.config().K;
    msgs.info.header = header;
    msgs.info.width = static_cast<uint32_t>(K.width);
    msgs.info.height = static_cast<uint32_t>(K.height);
    msgs.info.distortion_model = "plumb_bob";
    msgs.info.D.assign(5, 0.0);
    msgs.info.K = {K.fx, 0.0, K.cx, 0.0, K.fy, K.cy, 0.0, 0.0, 1.0};
    msgs.info.R = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
    msgs.info.P = {K.fx, 0.0, K.cx, 0.0, 0.0, K.fy, K.cy, 0.0, 0.0, 0.0, 1.0, 0.0};

    msgs.pose.header.stamp = stamp;
    msgs.pose.header.frame_id = kWorldFrame;
    msgs.pose.pose = toPoseMsg(scene_.cameraPose(index));

    msgs.detections.header = header;
    for (const mvod::Detection2D& detection :
         scene_.detectionsFromLabels(labels, options_.min_mask_pixels)) {
      std::string class_name = detection.class_name;
      std::vector<cv::Point> pixels;
      cv::findNonZero(detection.mask, pixels);
      if (pixels.empty()) continue;
      const int object_index = labels.at<int32_t>(pixels.front()) - 1;
      const auto relabelled = options_.relabel.find(object_index);
      if (relabelled != options_.relabel.end()) class_name = relabelled->second;
      sensor_msgs::RegionOfInterest box;
      box.x_offset = static_cast<uint32_t>(detection.box_px.x);
      box.y_offset = static_cast<uint32_t>(detection.box_px.y);
      box.width = static_cast<uint32_t>(detection.box_px.width);
      box.height = static_cast<uint32_t>(detection.box_px.height);
      msgs.detections.boxes.push_back(box);
      msgs.detections.class_ids.push_back(mvod::cocoClassId(class_name));
      msgs.detections.class_names.push_back(class_name);
      msgs.detections.scores.push_back(0.9f);
      msgs.detections.masks.push_back(toImageMsg(detection.mask, "mono8", header));
    }
    return msgs;
  }

 private:
  static mvod::SyntheticSceneConfig sceneConfig(const Options& options) {
    mvod::SyntheticSceneConfig config;
    config.num_frames = options.num_frames;
    const double scale = options.width / 640.0;
    config.K = mvod::CameraIntrinsics{
        525.0 * scale, 525.0 * scale, (options.width - 1) / 2.0, (options.height - 1) / 2.0,
        options.width, options.height};
    return config;
  }

  static mvod::SyntheticScene changedScene(const Options& options) {
    const mvod::SyntheticScene room = mvod::SyntheticScene::makeDefault(sceneConfig(options));
    if (options.moved.empty() && options.removed.empty()) return room;
    std::vector<mvod::SyntheticObject> objects;
    for (int i = 0; i < static_cast<int>(room.objects().size()); ++i) {
      if (options.removed.count(i)) continue;
      mvod::SyntheticObject object = room.objects()[i];
      const auto move = options.moved.find(i);
      if (move != options.moved.end()) {
        object.box.center_m += move->second;
        for (mvod::OrientedBox& part : object.parts) part.center_m += move->second;
      }
      objects.push_back(object);
    }
    return mvod::SyntheticScene(room.config(), objects, room.clutter());
  }

  Options options_;
  mvod::SyntheticScene scene_;
};

// Publishes FrameMsgs on the test topics (and the camera pose on TF when asked).
class InputPublisher {
 public:
  explicit InputPublisher(ros::NodeHandle& nh) {
    rgb_ = nh.advertise<sensor_msgs::Image>(kRgbTopic, 10);
    depth_ = nh.advertise<sensor_msgs::Image>(kDepthTopic, 10);
    info_ = nh.advertise<sensor_msgs::CameraInfo>(kInfoTopic, 10);
    pose_ = nh.advertise<geometry_msgs::PoseStamped>(kPoseTopic, 10);
    detections_ =
        nh.advertise<multiview_object_detection::InstanceDetections>(kDetectionsTopic, 10);
  }

  // True once the image inputs and the detections have `count` subscribers and the pose topic
  // `pose_count`.
  bool connected(unsigned count = 1, unsigned pose_count = 1) const {
    return rgb_.getNumSubscribers() >= count && depth_.getNumSubscribers() >= count &&
           info_.getNumSubscribers() >= count && detections_.getNumSubscribers() >= count &&
           pose_.getNumSubscribers() >= pose_count;
  }

  // The pose and the detections go first, as a SLAM and a detector host that keep up would send
  // them.
  void publish(const FrameMsgs& msgs, bool with_pose = true, bool with_detections = true,
               bool with_tf = false) {
    if (with_tf) publishTf(msgs.pose);
    if (with_pose) pose_.publish(msgs.pose);
    if (with_detections) detections_.publish(msgs.detections);
    ros::WallDuration(0.02).sleep();
    info_.publish(msgs.info);
    depth_.publish(msgs.depth);
    rgb_.publish(msgs.rgb);
  }

  void publishTf(const geometry_msgs::PoseStamped& pose) {
    geometry_msgs::TransformStamped transform;
    transform.header = pose.header;
    transform.child_frame_id = kCameraFrame;
    transform.transform.translation.x = pose.pose.position.x;
    transform.transform.translation.y = pose.pose.position.y;
    transform.transform.translation.z = pose.pose.position.z;
    transform.transform.rotation = pose.pose.orientation;
    tf_.sendTransform(transform);
  }

  ros::Publisher rgb_, depth_, info_, pose_, detections_;

 private:
  tf2_ros::TransformBroadcaster tf_;
};

// What the node has published, collected on the spinner's thread.
class NodeOutputs {
 public:
  using Marker = visualization_msgs::Marker;
  using MarkerKey = std::pair<std::string, int>;  // namespace, id

  explicit NodeOutputs(ros::NodeHandle& nh, const std::string& node = "/object_detection",
                       bool subscribe_rosout = false)
      : node_(node) {
    objects_sub_ = nh.subscribe(node + "/objects", 100, &NodeOutputs::onObjects, this);
    markers_sub_ = nh.subscribe(node + "/markers", 100, &NodeOutputs::onMarkers, this);
    keyframes_sub_ = nh.subscribe(node + "/keyframes", 100, &NodeOutputs::onKeyframes, this);
    if (subscribe_rosout) rosout_sub_ = nh.subscribe("/rosout", 1000, &NodeOutputs::onLog, this);
  }

  // The subscriptions end before the data their callbacks write is destroyed (members go in
  // reverse order, the subscribers last): the spinner's threads may still be delivering messages.
  // Subscriber::shutdown() waits for a callback in progress.
  ~NodeOutputs() {
    for (ros::Subscriber* sub : {&objects_sub_, &markers_sub_, &keyframes_sub_, &rosout_sub_}) {
      sub->shutdown();
    }
  }
  NodeOutputs(const NodeOutputs&) = delete;
  NodeOutputs& operator=(const NodeOutputs&) = delete;

  bool connected() const {
    return objects_sub_.getNumPublishers() > 0 && markers_sub_.getNumPublishers() > 0;
  }

  // Polls `done` until it holds or the timeout passes (`done` may call the accessors below).
  bool waitFor(const std::function<bool()>& done, double timeout_s) const {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
    while (ros::ok() && ros::WallTime::now() < deadline) {
      if (done()) return true;
      ros::WallDuration(0.02).sleep();
    }
    return done();
  }

  bool hasObjectsAt(const ros::Time& stamp) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return object_stamps_.count(stamp) > 0;
  }
  bool waitForObjectsAt(const ros::Time& stamp, double timeout_s) const {
    return waitFor([&] { return hasObjectsAt(stamp); }, timeout_s);
  }
  bool waitForObjectsCount(size_t count, double timeout_s) const {
    return waitFor([&] { return objectsReceived() >= count; }, timeout_s);
  }

  multiview_object_detection::ObjectArray lastObjects() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return last_objects_;
  }
  size_t objectsReceived() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return objects_received_;
  }
  size_t keyframePoses() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return last_path_.poses.size();
  }
  nav_msgs::Path lastPath() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return last_path_;
  }
  // Markers currently shown (after applying ADD / DELETE / DELETEALL in order).
  std::map<MarkerKey, Marker> markers() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return markers_;
  }
  // Ids of the markers shown in namespace `ns`.
  std::set<int> shownIds(const std::string& ns) const {
    std::set<int> ids;
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& entry : markers_) {
      if (entry.first.first == ns) ids.insert(entry.first.second);
    }
    return ids;
  }
  // (namespace, id) of every marker that was shown and then deleted.
  std::set<MarkerKey> deletedMarkers() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return deleted_;
  }
  std::vector<rosgraph_msgs::Log> logs() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return logs_;
  }

  // The node's WARN or worse messages containing every one of `all` and at least one of `any`
  // (case-insensitive), logged after `since`.
  std::vector<std::string> findLogs(const std::vector<std::string>& all,
                                    const std::vector<std::string>& any,
                                    const ros::Time& since = ros::Time(0)) const {
    std::vector<std::string> found;
    std::lock_guard<std::mutex> lock(mutex_);
    for (const rosgraph_msgs::Log& log : logs_) {
      if (log.name != node_ || log.level < rosgraph_msgs::Log::WARN) continue;
      if (log.header.stamp < since) continue;
      const std::string text = lower(log.msg);
      const bool has_all = std::all_of(all.begin(), all.end(), [&](const std::string& word) {
        return text.find(lower(word)) != std::string::npos;
      });
      const bool has_any =
          any.empty() || std::any_of(any.begin(), any.end(), [&](const std::string& word) {
            return text.find(lower(word)) != std::string::npos;
          });
      if (has_all && has_any) found.push_back(log.msg);
    }
    return found;
  }

  std::string allLogs() const {
    std::string text;
    std::lock_guard<std::mutex> lock(mutex_);
    for (const rosgraph_msgs::Log& log : logs_) {
      if (log.name == node_) text += "  [" + std::to_string(log.level) + "] " + log.msg + "\n";
    }
    return text;
  }

  static std::string lower(std::string text) {
    std::transform(text.begin(), text.end(), text.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return text;
  }

 private:
  void onObjects(const multiview_object_detection::ObjectArray& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    last_objects_ = msg;
    object_stamps_.insert(msg.header.stamp);
    ++objects_received_;
  }
  void onMarkers(const visualization_msgs::MarkerArray& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const Marker& marker : msg.markers) {
      const MarkerKey key(marker.ns, marker.id);
      if (marker.action == Marker::DELETEALL) {
        for (const auto& shown : markers_) deleted_.insert(shown.first);
        markers_.clear();
      } else if (marker.action == Marker::DELETE) {
        if (markers_.erase(key) > 0) deleted_.insert(key);
      } else {
        markers_[key] = marker;
        deleted_.erase(key);
      }
    }
  }
  void onKeyframes(const nav_msgs::Path& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    last_path_ = msg;
  }
  void onLog(const rosgraph_msgs::Log& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    logs_.push_back(msg);
  }

  std::string node_;
  ros::Subscriber objects_sub_, markers_sub_, keyframes_sub_, rosout_sub_;
  mutable std::mutex mutex_;
  multiview_object_detection::ObjectArray last_objects_;
  std::set<ros::Time> object_stamps_;
  size_t objects_received_ = 0;
  nav_msgs::Path last_path_;
  std::map<MarkerKey, Marker> markers_;
  std::set<MarkerKey> deleted_;
  std::vector<rosgraph_msgs::Log> logs_;
};

// The main() of a rostest gtest: ROS initialised, callbacks served by two threads while the tests
// run.
inline int runRosTests(int argc, char** argv, const char* node_name) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, node_name);
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  spinner.stop();
  ros::shutdown();
  return result;
}

// An object's box centre.
inline Eigen::Vector3d centerOf(const multiview_object_detection::Object& object) {
  return Eigen::Vector3d(object.pose.position.x, object.pose.position.y, object.pose.position.z);
}

// ~get_objects of `node`, all objects.
inline multiview_object_detection::ObjectArray getObjects(const std::string& node) {
  multiview_object_detection::GetObjects srv;
  EXPECT_TRUE(ros::service::call(node + "/get_objects", srv));
  return srv.response.objects;
}

// `from`'s map saved to a temporary file and loaded into `to`; the failure's reason, or "".
inline std::string copyMap(const std::string& from, const std::string& to) {
  const std::string path = "/tmp/mvod_rostest_map_" + std::to_string(::getpid()) + "_" +
                           std::to_string(std::rand()) + ".mvmap";
  multiview_object_detection::MapFile save, load;
  save.request.path = path;
  load.request.path = path;
  if (!ros::service::call(from + "/save_map", save)) return from + "/save_map not called";
  if (!save.response.success) return save.response.message;
  const bool called = ros::service::call(to + "/load_map", load);
  std::filesystem::remove_all(path);
  if (!called) return to + "/load_map not called";
  return load.response.success ? std::string() : load.response.message;
}

}  // namespace mvod_test
