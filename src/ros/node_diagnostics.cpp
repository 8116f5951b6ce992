#include "multiview_object_detection/ros/node_diagnostics.h"

#include <diagnostic_msgs/DiagnosticStatus.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <limits>
#include <string>
#include <utility>

namespace mvod {
namespace {

using diagnostic_msgs::DiagnosticStatus;

}  // namespace

NodeDiagnostics::NodeDiagnostics(const ros::NodeHandle& nh, const ros::NodeHandle& nh_private,
                                 SharedStatistics* stats, double period_s)
    : stats_(stats),
      updater_(std::make_unique<diagnostic_updater::Updater>(nh, nh_private)),
      nh_(nh),
      period_s_(period_s) {
  // A software node: no device of its own (the camera is the driver's); the node's name tells
  // which of several mappers a status is from.
  updater_->setHardwareID(nh_private.getNamespace());
  updater_->add("map", this, &NodeDiagnostics::mapStatus);
}

void NodeDiagnostics::start() {
  addInputTasks();
  timer_ = nh_.createWallTimer(ros::WallDuration(period_s_), &NodeDiagnostics::update, this);
}

void NodeDiagnostics::stop() { timer_.stop(); }

void NodeDiagnostics::addInputTasks() {
  for (const InputMonitor::Report& report : stats_->inputs().reports()) {
    const std::string topic = report.topic;
    updater_->add("input " + topic, [this, topic](diagnostic_updater::DiagnosticStatusWrapper& s) {
      inputStatus(topic, s);
    });
  }
}

namespace {

// The process's resident memory (MB; NaN where /proc cannot tell): what the history bound, the
// queue's and the map's memory add up to, plus the code and the detector's network.
double residentMb() {
  std::ifstream statm("/proc/self/statm");
  double pages_total = 0.0;
  double pages_resident = 0.0;
  if (!(statm >> pages_total >> pages_resident)) return std::numeric_limits<double>::quiet_NaN();
  return pages_resident * static_cast<double>(::sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

}  // namespace

void NodeDiagnostics::update(const ros::WallTimerEvent& /*event*/) {
  const ros::Time clock = ros::Time::now();
  const ros::WallTime wall = ros::WallTime::now();
  if (clock != last_clock_) {
    last_clock_ = clock;
    clock_moved_ = wall;
  }
  clock_.sim_time = ros::Time::isSimTime();
  clock_.started = !clock.isZero();
  clock_.still_s = (wall - clock_moved_).toSec();
  // force_update: Updater::update() follows ros::Time, which stands still while a bag is paused.
  updater_->force_update();
}

void NodeDiagnostics::inputStatus(const std::string& topic,
                                  diagnostic_updater::DiagnosticStatusWrapper& status) {
  InputMonitor::Report report;
  for (InputMonitor::Report& r : stats_->inputs().reports(InputMonitor::Clock::now(), clock_)) {
    if (r.topic == topic) report = std::move(r);
  }
  status.summary(static_cast<unsigned char>(report.level), report.message);
  status.add("topic", topic);
  status.add("rate hz", report.rate_hz);
  status.add("silent s", report.silent_s);
  status.add("messages", report.messages);
  // Logged once when it goes silent, once when it is back.
  int& last = input_levels_[topic];
  if (report.level == InputMonitor::kError && last != InputMonitor::kError) {
    ROS_ERROR("%s", report.message.c_str());
  } else if (report.level != InputMonitor::kError && last == InputMonitor::kError) {
    ROS_INFO("'%s' is back: %s", topic.c_str(), report.message.c_str());
  }
  last = report.level;
}

void NodeDiagnostics::mapStatus(diagnostic_updater::DiagnosticStatusWrapper& status) {
  const ObjectDetectionStatistics stats = stats_->get();
  status.summary(DiagnosticStatus::OK, "ok");
  if (stats.keyframes_dropped > dropped_at_last_) {
    status.summary(DiagnosticStatus::WARN,
                   "keyframes dropped: processing is slower than the keyframe rate");
  } else if (stats.frames_lost > lost_at_last_) {
    char text[240];
    std::snprintf(
        text, sizeof(text),
        "%d of %d frames (%.1f %%) lost before the node: gaps in the colour images' "
        "sequence numbers or stamps (a full subscriber queue, the network or the driver)",
        stats.frames_lost, stats.frames_lost + stats.frames_received,
        100.0 * stats.frames_lost / std::max(1, stats.frames_lost + stats.frames_received));
    status.summary(DiagnosticStatus::WARN, text);
  } else if (stats.autosave_failures > autosave_failures_at_last_) {
    status.summary(DiagnosticStatus::WARN,
                   "autosave failed (the previous autosave is kept; see the log)");
  } else if (stats.callback_exceptions > exceptions_at_last_) {
    status.summary(DiagnosticStatus::WARN,
                   "a callback failed with an exception (input dropped; see the log)");
  } else if (stats.keyframes_faulty > faulty_at_last_) {
    status.summary(DiagnosticStatus::WARN,
                   "a keyframe's depth contradicted most of the map (a sensor or SLAM fault): "
                   "not fused, no votes (see the log)");
  } else if (stats.stamps_refused > refused_at_last_) {
    status.summary(DiagnosticStatus::WARN,
                   "input refused for its stamp (past 2038 or far ahead of the clock)");
  } else if (stats.waiting_for_gravity) {
    status.summary(DiagnosticStatus::WARN, "waiting for gravity");
  }
  if (!stats.tf_stamp_problem.empty()) {
    status.mergeSummary(DiagnosticStatus::WARN, stats.tf_stamp_problem);
  }
  // The autosave not where it should be, or failing: ERROR until it is well (it says what to do).
  if (!stats.autosave_problem.empty()) {
    status.mergeSummary(DiagnosticStatus::ERROR, stats.autosave_problem);
  }
  rejections_.add(ros::WallTime::now().toSec(),
                  {stats.frames_received, stats.frames_rejected, stats.pose_failures});
  const RejectionWindow::Report rejected =
      rejections_.report(stats.last_frame_rejection, stats.last_pose_failure);
  if (rejected.level != RejectionWindow::kOk) {
    status.mergeSummary(static_cast<unsigned char>(rejected.level), rejected.message);
  }
  dropped_at_last_ = stats.keyframes_dropped;
  lost_at_last_ = stats.frames_lost;
  exceptions_at_last_ = stats.callback_exceptions;
  refused_at_last_ = stats.stamps_refused;
  faulty_at_last_ = stats.keyframes_faulty;
  autosave_failures_at_last_ = stats.autosave_failures;
  const std::pair<const char*, double> values[] = {
      {"frames received", stats.frames_received},
      {"frames rejected", stats.frames_rejected},
      {"frames lost before the node", stats.frames_lost},
      {"stamps refused", stats.stamps_refused},
      {"callback exceptions", stats.callback_exceptions},
      {"autosaves", stats.autosaves},
      {"autosave failures", stats.autosave_failures},
      {"autosave ms", stats.autosave_ms},
      {"autosave bytes", stats.autosave_bytes},
      {"autosave written bytes", stats.autosave_written_bytes},
      {"pose failures", stats.pose_failures},
      {"time jumps back", stats.time_jumps},
      {"detections capped", stats.detections_capped},
      {"keyframes selected", stats.keyframes_selected},
      {"keyframes dropped", stats.keyframes_dropped},
      {"keyframes cancelled", stats.keyframes_cancelled},
      {"keyframes processed", stats.keyframes_processed},
      {"keyframes failed", stats.keyframes_failed},
      {"keyframes taken for faults", stats.keyframes_faulty},
      {"queue length", stats.queue_length},
      {"queue MB", stats.queue_mb},
      {"process RSS MB", residentMb()},
      {"objects", stats.objects},
      {"removed atypical", stats.removed_atypical},
      {"removed intersecting", stats.removed_intersecting},
      {"detection ms", stats.detection_ms},
      {"extraction ms", stats.stage_times.extraction_ms},
      {"filter ms", stats.stage_times.filter_ms},
      {"lccp ms", stats.stage_times.lccp_ms},
      {"manhattan ms", stats.stage_times.manhattan_ms},
      {"fusion ms", stats.stage_times.fusion_ms},
      {"existence ms", stats.stage_times.existence_ms},
      {"largest view ms", stats.stage_times.largest_view_ms},
      {"refinement ms", stats.stage_times.refinement_ms},
      {"keyframe total ms", stats.stage_times.total_ms},
      {"detection median ms", stats.detection_median_ms},
      {"keyframe total median ms", stats.keyframe_total_median_ms},
      {"latency ms", stats.latency_ms},
      {"latency median ms", stats.latency_median_ms},
      {"removed gone", stats.removed_gone},
      {"removed by corrections", stats.removed_by_corrections},
      {"keyframe pose messages", stats.keyframe_pose_messages},
      {"keyframe poses refused", stats.keyframe_poses_refused},
      {"keyframe poses unmatched", stats.keyframe_poses_unmatched},
      {"corrections applied", stats.corrections_applied},
      {"keyframes corrected", stats.keyframes_corrected},
      {"correction ms", stats.correction_ms},
      {"history MB", stats.history_mb},
      {"history keyframes", stats.history_keyframes},
      {"history full depth", stats.history_full_depth},
      {"history coarse depth", stats.history_coarse_depth},
      {"history views only", stats.history_views_only},
      {"history forgotten", stats.history_forgotten},
  };
  for (const auto& [key, value] : values) status.add(key, value);
  if (!stats.autosave_folder.empty()) status.add("autosave folder", stats.autosave_folder);
}

}  // namespace mvod
