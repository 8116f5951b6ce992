// object_detection_node: the ROS node around ObjectDetectionRos (all the work is there).
#include <ros/ros.h>

#include <csignal>

#include "multiview_object_detection/ros/object_detection_ros.h"

namespace {
volatile std::sig_atomic_t g_sigint = 0;
}  // namespace

int main(int argc, char** argv) {
  // Own SIGINT handling: the final refinement is published while ROS is still up.
  ros::init(argc, argv, "object_detection", ros::init_options::NoSigintHandler);
  // SIGTERM (roslaunch's second try, systemd, docker stop) too: the map is refined and autosaved.
  std::signal(SIGINT, [](int) { g_sigint = 1; });
  std::signal(SIGTERM, [](int) { g_sigint = 1; });
  ros::NodeHandle nh;
  ros::NodeHandle nh_private("~");
  mvod::ObjectDetectionRos node(nh, nh_private);
  if (!node.ok()) return EXIT_FAILURE;
  const ros::WallTimer stop = nh.createWallTimer(ros::WallDuration(0.1), [&node](const auto&) {
    if (g_sigint) {
      node.shutdown();
      ros::requestShutdown();
    }
  });
  ros::spin();
  node.shutdown();
  return EXIT_SUCCESS;
}
