#include "multiview_object_detection/ros/throttled_log.h"

#include <ros/console.h>

#include <cctype>
#include <chrono>
#include <map>
#include <mutex>

namespace mvod {

bool shouldLog(const std::string& text) {
  using Clock = std::chrono::steady_clock;
  // One table for the whole node: a problem seen by two stages is still throttled once.
  static std::mutex mutex;
  static std::map<std::string, Clock::time_point> last_logged;
  std::string key;
  key.reserve(text.size());
  for (const char c : text) {
    if (!std::isdigit(static_cast<unsigned char>(c))) key.push_back(c);
  }
  std::lock_guard<std::mutex> lock(mutex);
  if (last_logged.size() > 1000) last_logged.clear();
  const Clock::time_point now = Clock::now();
  const auto it = last_logged.find(key);
  if (it != last_logged.end() &&
      std::chrono::duration<double>(now - it->second).count() < kLogThrottlePeriodS) {
    return false;
  }
  last_logged[key] = now;
  return true;
}

void errorThrottled(const std::string& text) {
  if (shouldLog(text)) ROS_ERROR("%s", text.c_str());
}

void warnThrottled(const std::string& text) {
  if (shouldLog(text)) ROS_WARN("%s", text.c_str());
}

}  // namespace mvod
