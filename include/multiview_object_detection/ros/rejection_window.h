// What share of the node's input it refused lately: frames rejected (bad encoding, size,
// camera_info, an out-of-order stamp) of the frames received, and camera poses that failed (no TF,
// no pose in time, an invalid pose) of the frames that needed one, over the last window_s. The map
// status on /diagnostics turns WARN when any input was refused in the window and ERROR when at
// least half of it was (and at least kMinForError times): a node that rejects everything is not
// "ok" (as amcl and robot_localization report). ROS-free; fed the node's counters once a second.
#pragma once

#include <deque>
#include <string>

namespace mvod {

class RejectionWindow {
 public:
  // The node's counters since its start.
  struct Totals {
    long frames_received = 0;
    long frames_rejected = 0;
    long pose_failures = 0;
  };
  // diagnostic_msgs::DiagnosticStatus's levels.
  enum Level { kOk = 0, kWarn = 1, kError = 2 };
  struct Report {
    Level level = kOk;
    std::string message;  // empty when kOk
  };
  static constexpr long kMinForError = 3;

  explicit RejectionWindow(double window_s = 10.0) : window_s_(window_s) {}

  void add(double time_s, const Totals& totals);
  // The window's shares; the reasons are the last ones the node gave (for the message).
  Report report(const std::string& last_frame_rejection,
                const std::string& last_pose_failure) const;
  double windowS() const { return window_s_; }

 private:
  struct Sample {
    double time_s = 0.0;
    Totals totals;
  };
  double window_s_;
  std::deque<Sample> samples_;
};

}  // namespace mvod
