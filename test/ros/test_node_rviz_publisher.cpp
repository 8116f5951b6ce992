// The input side of rviz_screenshot.test: on "start" (std_msgs/String on /rviz_test/command) it
// publishes one lap of the synthetic scene to object_detection_node (colour, depth, camera_info, TF
// and detections), waits for each keyframe's ~objects and then reports on /rviz_test/status
// (latched):
//   "published <objects> boxes=<r,g,b;...> clouds=<r,g,b;...>"  the box and object-cloud colours
//   (0-255)
// On "reset" it calls ~reset and reports "reset <boxes shown>". Meanwhile it keeps the last camera
// pose on TF so rviz has the map frame.
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_msgs/String.h>
#include <std_srvs/Trigger.h>

#include <cstdio>
#include <deque>
#include <set>
#include <sstream>
#include <tuple>

#include "test_node_common.h"

namespace mvod_test {
namespace {

using Rgb = std::tuple<int, int, int>;

std::string joinColors(const std::set<Rgb>& colors) {
  std::ostringstream text;
  bool first = true;
  for (const Rgb& c : colors) {
    text << (first ? "" : ";") << std::get<0>(c) << "," << std::get<1>(c) << "," << std::get<2>(c);
    first = false;
  }
  return text.str();
}

class RvizTestPublisher {
 public:
  explicit RvizTestPublisher(ros::NodeHandle& nh)
      : nh_(nh),
        stream_(SyntheticStream::Options()),
        inputs_(nh),
        outputs_(nh, "/object_detection") {
    status_pub_ = nh.advertise<std_msgs::String>("/rviz_test/status", 1, true);
    command_sub_ = nh.subscribe("/rviz_test/command", 10, &RvizTestPublisher::onCommand, this);
    cloud_sub_ =
        nh.subscribe("/object_detection/object_cloud", 10, &RvizTestPublisher::onCloud, this);
  }

  void run() {
    ros::Rate rate(10.0);
    while (ros::ok()) {
      const std::string command = takeCommand();
      if (command == "start") publishLap();
      if (command == "reset") reset();
      if (!last_pose_.header.frame_id.empty()) {
        geometry_msgs::PoseStamped pose = last_pose_;
        pose.header.stamp = ros::Time::now();
        inputs_.publishTf(pose);
      }
      rate.sleep();
    }
  }

 private:
  void onCommand(const std_msgs::String& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    commands_.push_back(msg.data);
  }
  std::string takeCommand() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (commands_.empty()) return std::string();
    const std::string command = commands_.front();
    commands_.pop_front();
    return command;
  }
  void onCloud(const sensor_msgs::PointCloud2& cloud) {
    std::set<Rgb> colors;
    int rgb_offset = -1;
    for (const sensor_msgs::PointField& field : cloud.fields) {
      if (field.name == "rgb") rgb_offset = static_cast<int>(field.offset);
    }
    if (rgb_offset >= 0) {
      const size_t points = static_cast<size_t>(cloud.width) * cloud.height;
      for (size_t i = 0; i < points; ++i) {
        uint32_t packed;
        std::memcpy(&packed, &cloud.data[i * cloud.point_step + rgb_offset], sizeof(packed));
        colors.insert(Rgb((packed >> 16) & 0xff, (packed >> 8) & 0xff, packed & 0xff));
      }
    }
    std::lock_guard<std::mutex> lock(mutex_);
    cloud_colors_ = colors;
  }

  void report(const std::string& text) {
    std_msgs::String msg;
    msg.data = text;
    status_pub_.publish(msg);
    ROS_INFO("rviz_test_publisher: %s", text.c_str());
  }

  void publishLap() {
    if (!outputs_.waitFor([&] { return inputs_.connected(1, 0) && outputs_.connected(); }, 30.0)) {
      report("error: object_detection did not connect");
      return;
    }
    const ros::Time start = ros::Time::now();
    int processed = 0;
    for (int i = 0; i < stream_.options().num_frames; ++i) {
      const FrameMsgs frame = stream_.make(i, start + ros::Duration(0.5 * i));
      inputs_.publish(frame, true, true, true);
      last_pose_ = frame.pose;
      processed += outputs_.waitForObjectsAt(frame.pose.header.stamp, 20.0) ? 1 : 0;
    }
    ros::WallDuration(1.0).sleep();  // the last cloud
    std::set<Rgb> box_colors;
    for (const auto& entry : outputs_.markers()) {
      if (entry.first.first != "boxes") continue;
      const std_msgs::ColorRGBA& c = entry.second.color;
      box_colors.insert(Rgb(static_cast<int>(c.r * 255.f + 0.5f),
                            static_cast<int>(c.g * 255.f + 0.5f),
                            static_cast<int>(c.b * 255.f + 0.5f)));
    }
    std::set<Rgb> cloud_colors;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      cloud_colors = cloud_colors_;
    }
    report("published " + std::to_string(outputs_.lastObjects().objects.size()) + " objects " +
           std::to_string(processed) + " keyframes boxes=" + joinColors(box_colors) +
           " clouds=" + joinColors(cloud_colors));
  }

  void reset() {
    std_srvs::Trigger srv;
    const bool called = ros::service::call("/object_detection/reset", srv) && srv.response.success;
    outputs_.waitFor([&] { return outputs_.shownIds("boxes").empty(); }, 5.0);
    report(std::string(called ? "reset" : "reset failed") + " " +
           std::to_string(outputs_.shownIds("boxes").size()));
  }

  ros::NodeHandle& nh_;
  SyntheticStream stream_;
  InputPublisher inputs_;
  NodeOutputs outputs_;
  ros::Publisher status_pub_;
  ros::Subscriber command_sub_, cloud_sub_;
  std::mutex mutex_;
  std::deque<std::string> commands_;
  std::set<Rgb> cloud_colors_;
  geometry_msgs::PoseStamped last_pose_;
};

}  // namespace
}  // namespace mvod_test

int main(int argc, char** argv) {
  ros::init(argc, argv, "rviz_test_publisher");
  ros::NodeHandle nh;
  ros::AsyncSpinner spinner(2);
  spinner.start();
  mvod_test::RvizTestPublisher publisher(nh);
  publisher.run();
  return 0;
}
