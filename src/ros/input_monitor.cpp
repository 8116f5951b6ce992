#include "multiview_object_detection/ros/input_monitor.h"

#include <algorithm>
#include <cstdio>

namespace mvod {
namespace {

double secondsBetween(InputMonitor::Clock::time_point from, InputMonitor::Clock::time_point to) {
  return std::chrono::duration<double>(to - from).count();
}

std::string fixed(double value, int decimals) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", decimals, value);
  return text;
}

}  // namespace

void InputMonitor::configure(const Config& config, Clock::time_point start) {
  std::lock_guard<std::mutex> lock(mutex_);
  config_ = config;
  start_ = start;
}

void InputMonitor::expect(const std::string& topic, bool check_rate) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (inputs_.count(topic) == 0) order_.push_back(topic);
  inputs_[topic].check_rate = check_rate;
}

void InputMonitor::received(const std::string& topic, Clock::time_point now) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = inputs_.find(topic);
  if (found == inputs_.end()) return;
  Input& input = found->second;
  ++input.messages;
  input.last = now;
  input.recent.push_back(now);
  const auto window =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(kRateWindowS));
  while (!input.recent.empty() && input.recent.front() < now - window) input.recent.pop_front();
  // A flood (thousands per second) keeps a bounded deque: the rate is then "at least" this.
  if (input.recent.size() > 100000) input.recent.pop_front();
}

std::vector<InputMonitor::Report> InputMonitor::reports(Clock::time_point now,
                                                        const ClockState& clock) const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<Report> out;
  for (const std::string& topic : order_) {
    out.push_back(report(topic, inputs_.at(topic), now));
    judgeWithClock(clock, &out.back());
  }
  return out;
}

void InputMonitor::judgeWithClock(const ClockState& clock, Report* r) const {
  if (!clock.sim_time || r->level != kError || clock.still_s < config_.timeout_s) return;
  if (!clock.started) {
    r->level = kWarn;
    r->message = "use_sim_time is set and no /clock came in " + fixed(clock.still_s, 0) +
                 " s, nor anything on '" + r->topic + "': is a bag playing (rosbag play --clock)?";
    return;
  }
  // The input went quiet when the clock stopped (within a second of it): the bag paused or ended.
  if (r->messages > 0 && r->silent_s <= clock.still_s + 1.0) {
    r->level = kOk;
    r->message = "the clock stopped " + fixed(clock.still_s, 0) +
                 " s ago (a bag paused or ended); nothing on '" + r->topic + "' since";
  }
}

InputMonitor::Report InputMonitor::report(const std::string& topic, const Input& input,
                                          Clock::time_point now) const {
  Report r;
  r.topic = topic;
  r.messages = input.messages;
  const double running_s = secondsBetween(start_, now);
  r.silent_s = input.messages > 0 ? secondsBetween(input.last, now) : running_s;
  const double window_s = std::min(kRateWindowS, running_s);
  const long in_window = static_cast<long>(
      std::count_if(input.recent.begin(), input.recent.end(),
                    [&](Clock::time_point t) { return secondsBetween(t, now) <= kRateWindowS; }));
  r.rate_hz = window_s > 0.0 ? static_cast<double>(in_window) / window_s : 0.0;
  if (input.messages == 0 && running_s >= config_.timeout_s) {
    r.level = kError;
    r.message = "no message on '" + topic + "' in the " + fixed(running_s, 0) +
                " s since the start: is it remapped to the publisher's topic?";
  } else if (input.messages == 0) {
    r.message = "waiting for the first message on '" + topic + "'";
  } else if (r.silent_s >= config_.timeout_s) {
    r.level = kError;
    r.message = "nothing on '" + topic + "' for " + fixed(r.silent_s, 0) + " s";
  } else if (input.check_rate && running_s >= kRateWindowS && r.rate_hz < config_.min_rate_hz) {
    r.level = kWarn;
    r.message = "'" + topic + "' at " + fixed(r.rate_hz, 1) + " Hz, below input_min_rate_hz " +
                fixed(config_.min_rate_hz, 1);
  } else {
    r.message = fixed(r.rate_hz, 1) + " Hz";
  }
  return r;
}

}  // namespace mvod
