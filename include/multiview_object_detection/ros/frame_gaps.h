// Frames lost before the node: the gaps in the colour images that reach the RGB-D callback. A full
// subscriber queue (the callback slower than the camera), the network or the driver drops frames
// without a word; the node sees them as missing sequence numbers (where the publisher numbers its
// images: a driver, `rosbag play`) or, where every header.seq is the same, as stamps further apart
// than the stream's frame period (the median of its recent steps).
#pragma once

#include <cstdint>
#include <deque>

namespace mvod {

class FrameGaps {
 public:
  // The next frame that reached the node; returns how many frames went missing just before it. A
  // stamp that does not move forward, or a sequence number that jumps back or by more than
  // kMaxSeqStep, or a stamp step of more than kRestartPeriods restarts the count (a bag played
  // again or paused, a restarted driver).
  int add(std::uint32_t seq, double stamp_s);
  long lost() const { return lost_; }
  long received() const { return received_; }

  static constexpr std::uint32_t kMaxSeqStep = 1000;
  // A step in stamps counts as a gap above this many frame periods.
  static constexpr double kGapPeriods = 1.5;
  // A step in stamps of more than this many periods of a steady stream restarts the count.
  static constexpr double kRestartPeriods = 50.0;
  // Stamps say nothing until this many steps have given the period.
  static constexpr std::size_t kMinSteps = 5;

 private:
  double period_s() const;
  bool isSteady() const;
  void restart(std::uint32_t seq, double stamp_s);

  bool has_last_ = false;
  std::uint32_t last_seq_ = 0;
  double last_stamp_s_ = 0.0;
  bool numbered_ = false;       // the publisher numbers its images (a seq step seen)
  std::deque<double> steps_s_;  // the recent periods (stamp step per frame)
  long lost_ = 0;
  long received_ = 0;
};

}  // namespace mvod
