// /diagnostics with diagnostic_updater, every diagnostic_period (wall time, so a paused bag still
// shows):
// "<node>: map" (queue, drops, failures, stage times; WARN on drops, failed autosaves, callback
// exceptions, refused stamps, waiting for gravity; WARN or ERROR with the share of frames rejected
// and camera poses failed over the last 10 s and the last reason: RejectionWindow) and "<node>:
// input <topic>" per expected input (InputMonitor: ERROR when it is silent, WARN when slow). An
// input going silent is also logged once, and its return.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>

#include <map>
#include <memory>
#include <string>

#include "multiview_object_detection/ros/input_monitor.h"
#include "multiview_object_detection/ros/object_detection_statistics.h"
#include "multiview_object_detection/ros/rejection_window.h"

namespace mvod {

class NodeDiagnostics {
 public:
  NodeDiagnostics(const ros::NodeHandle& nh, const ros::NodeHandle& nh_private,
                  SharedStatistics* stats, double period_s);
  // Call after the inputs are subscribed (their statuses are made then).
  void start();
  void stop();

 private:
  void update(const ros::WallTimerEvent& event);
  void addInputTasks();
  void mapStatus(diagnostic_updater::DiagnosticStatusWrapper& status);
  void inputStatus(const std::string& topic, diagnostic_updater::DiagnosticStatusWrapper& status);

  SharedStatistics* stats_;
  std::unique_ptr<diagnostic_updater::Updater> updater_;
  ros::NodeHandle nh_;
  double period_s_;
  ros::WallTimer timer_;
  // The timer's thread only.
  std::map<std::string, int> input_levels_;
  int dropped_at_last_ = 0;
  int lost_at_last_ = 0;
  int exceptions_at_last_ = 0;
  int refused_at_last_ = 0;
  int faulty_at_last_ = 0;
  int autosave_failures_at_last_ = 0;
  RejectionWindow rejections_;
  // The node's clock (ros::Time) when the timer last saw it move, and then (wall time).
  ros::Time last_clock_;
  ros::WallTime clock_moved_ = ros::WallTime::now();
  InputMonitor::ClockState clock_;
};

}  // namespace mvod
