// object_detection_node: the ROS node around ObjectDetectionRos (all the work is there).
#include <ros/ros.h>

#include <csignal>
#include <cstdlib>

#include "multiview_object_detection/ros/object_detection_ros.h"

namespace {
volatile std::sig_atomic_t g_sigint = 0;
}  // namespace

int main(int argc, char** argv) {
  // Own SIGINT handling: the final refinement is published while ROS is still up.
  ros::init(argc, argv, "object_detection", ros::init_options::NoSigintHandler);
  // SIGTERM (roslaunch's second try, systemd, docker stop) too: the map is refined and autosaved.
  // A second signal while that runs (a long keyframe still in the worker) ends the process at once;
  // the last autosave is then the map. A signal during the start (a map loading) is acted on once it
  // is up: nothing the start reads can block for good (map files and the map folder's lock are
  // opened without blocking, the lock waited for at most 120 s), and a second signal ends it at once.
  const auto on_signal = [](int) {
    if (g_sigint) std::_Exit(128 + SIGINT);
    g_sigint = 1;
  };
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
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
