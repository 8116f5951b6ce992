// Notices dead and slow inputs: every input callback reports its message here (the topic as
// remapped), and /diagnostics shows one status per expected input: ERROR when nothing came for
// timeout_s (a wrong remap shows within seconds of the start), WARN when it is slower than
// min_rate_hz, else OK with its rate. On a bag's clock (use_sim_time) silence is judged with the
// clock: inputs that went quiet when the clock stopped (a bag paused or ended) are OK and say so,
// and before the first /clock a WARN asks whether a bag plays. Thread-safe; `received` is cheap (a
// lock and a deque push).
#pragma once

#include <chrono>
#include <deque>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace mvod {

// The node's clock as InputMonitor's reports see it.
struct InputClockState {
  bool sim_time = false;  // use_sim_time: the clock comes from /clock (a bag)
  bool started = false;   // a /clock has come
  double still_s = 0.0;   // wall seconds since the clock last moved (or since the start)
};

class InputMonitor {
 public:
  using Clock = std::chrono::steady_clock;
  struct Config {
    double min_rate_hz = 1.0;  // slower: WARN (inputs checked for their rate)
    double timeout_s = 5.0;    // nothing for this long (or since the start): ERROR
  };
  // diagnostic_msgs::DiagnosticStatus's levels.
  enum Level { kOk = 0, kWarn = 1, kError = 2 };
  struct Report {
    std::string topic;
    Level level = kOk;
    std::string message;
    double rate_hz = 0.0;   // over the last kRateWindowS (or since the start, if shorter)
    double silent_s = 0.0;  // since the last message (or the start)
    long messages = 0;      // since the start
  };
  static constexpr double kRateWindowS = 5.0;
  using ClockState = InputClockState;

  void configure(const Config& config, Clock::time_point start = Clock::now());
  // An input the node needs; check_rate false: only its silence is an error (detections from a
  // detector that may run on keyframes only). Unexpected topics' messages are not tracked.
  void expect(const std::string& topic, bool check_rate);
  void received(const std::string& topic, Clock::time_point now = Clock::now());
  // One report per expected input, in the order they were expected.
  std::vector<Report> reports(Clock::time_point now = Clock::now(),
                              const ClockState& clock = ClockState()) const;

 private:
  struct Input {
    bool check_rate = true;
    long messages = 0;
    std::deque<Clock::time_point> recent;  // arrivals within kRateWindowS
    Clock::time_point last;
  };
  Report report(const std::string& topic, const Input& input, Clock::time_point now) const;
  // An ERROR for silence that the stopped clock explains becomes OK; no clock yet is a WARN.
  void judgeWithClock(const ClockState& clock, Report* report) const;

  mutable std::mutex mutex_;
  Config config_;
  Clock::time_point start_ = Clock::now();
  std::map<std::string, Input> inputs_;
  std::vector<std::string> order_;
};

}  // namespace mvod
