// object_detection_node: the ROS node around ObjectDetectionRos (all the work is there).
#include <ros/ros.h>

#include <csignal>
#include <cstdlib>

#include "multiview_object_detection/ros/object_detection_ros.h"

namespace {
volatile std::sig_atomic_t g_sigint = 0;
volatile std::sig_atomic_t g_running = 0;  // set once the node is up (its map loaded)
}  // namespace

int main(int argc, char** argv) {
  // Own SIGINT handling: the final refinement is published while ROS is still up.
  ros::init(argc, argv, "object_detection", ros::init_options::NoSigintHandler);
  // SIGTERM (roslaunch's second try, systemd, docker stop) too: the map is refined and autosaved.
  // A second signal while that runs (a long keyframe still in the worker) ends the process at once;
  // the last autosave is then the map. So does a signal before the node is up (a map loading at
  // start has nothing new to save, and must not keep the process from ending).
  const auto on_signal = [](int signal) {
    if (g_sigint || !g_running) std::_Exit(128 + signal);
    g_sigint = 1;
  };
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  ros::NodeHandle nh;
  ros::NodeHandle nh_private("~");
  mvod::ObjectDetectionRos node(nh, nh_private);
  if (!node.ok()) return EXIT_FAILURE;
  g_running = 1;
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
