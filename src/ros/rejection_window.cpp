#include "multiview_object_detection/ros/rejection_window.h"

#include <algorithm>
#include <cstdio>

namespace mvod {
namespace {

RejectionWindow::Level levelOf(long refused, long of) {
  if (refused <= 0) return RejectionWindow::kOk;
  if (refused >= RejectionWindow::kMinForError && 2 * refused >= of) return RejectionWindow::kError;
  return RejectionWindow::kWarn;
}

std::string share(long refused, long of, const char* what, double window_s,
                  const std::string& reason) {
  char text[160];
  std::snprintf(text, sizeof(text), "%ld of %ld %s in the last %.0f s", refused, of, what,
                window_s);
  return reason.empty() ? std::string(text) : std::string(text) + " (last: " + reason + ")";
}

}  // namespace

void RejectionWindow::add(double time_s, const Totals& totals) {
  samples_.push_back({time_s, totals});
  // Keep one sample at or before the window's start: the window's differences start there.
  while (samples_.size() > 2 && samples_[1].time_s <= time_s - window_s_) samples_.pop_front();
}

RejectionWindow::Report RejectionWindow::report(const std::string& last_frame_rejection,
                                                const std::string& last_pose_failure) const {
  Report out;
  if (samples_.size() < 2) return out;
  const Totals& first = samples_.front().totals;
  const Totals& last = samples_.back().totals;
  const long received = last.frames_received - first.frames_received;
  const long rejected = last.frames_rejected - first.frames_rejected;
  const long pose_failures = last.pose_failures - first.pose_failures;
  // Frames that needed a pose: the ones not rejected before the lookup (at least the failures).
  const long needing_pose = std::max(received - rejected, pose_failures);
  const double span_s = samples_.back().time_s - samples_.front().time_s;
  const Level frames = levelOf(rejected, std::max(received, rejected));
  const Level poses = levelOf(pose_failures, needing_pose);
  if (frames != kOk) {
    out.message = share(rejected, std::max(received, rejected), "frames rejected", span_s,
                        last_frame_rejection);
  }
  if (poses != kOk) {
    if (!out.message.empty()) out.message += "; ";
    out.message +=
        share(pose_failures, needing_pose, "camera poses failed", span_s, last_pose_failure);
  }
  out.level = std::max(frames, poses);
  return out;
}

}  // namespace mvod
