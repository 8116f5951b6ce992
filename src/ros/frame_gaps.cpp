#include "multiview_object_detection/ros/frame_gaps.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace mvod {
namespace {

constexpr std::size_t kRecentSteps = 15;

}  // namespace

int FrameGaps::add(std::uint32_t seq, double stamp_s) {
  ++received_;
  if (!has_last_ || !(stamp_s > last_stamp_s_) ||
      (numbered_ && (seq < last_seq_ || seq - last_seq_ > kMaxSeqStep))) {
    restart(seq, stamp_s);
    return 0;
  }
  const double step_s = stamp_s - last_stamp_s_;
  const std::uint32_t seq_step = seq - last_seq_;
  // The first numbered step only starts the numbering (frames numbered after unnumbered ones: a
  // restarted driver); gaps in numbers count from the next one on.
  const bool was_numbered = numbered_;
  if (seq_step != 0 && seq_step <= kMaxSeqStep) numbered_ = true;
  const int by_seq = numbered_ && was_numbered && seq_step > 1 ? static_cast<int>(seq_step - 1) : 0;
  // Stamps: a step of several periods of a steady stream. Frames a publisher never sent (a driver
  // that skipped them) leave no gap in its numbers, only in the stamps.
  int by_stamp = 0;
  if (isSteady() && step_s > kRestartPeriods * period_s()) {
    restart(seq, stamp_s);  // a paused bag, a restarted driver: a new stream, not lost frames
    return 0;
  }
  if (isSteady() && step_s > kGapPeriods * period_s()) {
    by_stamp = static_cast<int>(std::lround(step_s / period_s())) - 1;
  }
  const int missing = std::max(by_seq, by_stamp);
  steps_s_.push_back(step_s / (missing + 1));
  if (steps_s_.size() > kRecentSteps) steps_s_.pop_front();
  last_seq_ = seq;
  last_stamp_s_ = stamp_s;
  lost_ += missing;
  return missing;
}

double FrameGaps::period_s() const {
  std::vector<double> steps(steps_s_.begin(), steps_s_.end());
  std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
  return steps[steps.size() / 2];
}

bool FrameGaps::isSteady() const {
  // At least kMinSteps recent steps, 80 % of them within 25 % of their median: a camera's stream,
  // not the irregular stamps of a keyframe-only bag or a publisher at a varying rate.
  if (steps_s_.size() < kMinSteps) return false;
  const double period = period_s();
  const auto near = std::count_if(steps_s_.begin(), steps_s_.end(), [period](double step) {
    return std::abs(step - period) <= 0.25 * period;
  });
  return 5 * near >= 4 * static_cast<long>(steps_s_.size());
}

void FrameGaps::restart(std::uint32_t seq, double stamp_s) {
  has_last_ = true;
  last_seq_ = seq;
  last_stamp_s_ = stamp_s;
  numbered_ = false;
  steps_s_.clear();
}

}  // namespace mvod
