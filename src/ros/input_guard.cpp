#include "multiview_object_detection/ros/input_guard.h"

#include <cstdio>

namespace mvod {

std::string stampText(const ros::Time& stamp) {
  char text[32];
  std::snprintf(text, sizeof(text), "%u.%09u", stamp.sec, stamp.nsec);
  return text;
}

Status checkInputStamp(const ros::Time& stamp, const ros::Time& now, const std::string& what) {
  if (stamp.sec > kMaxInputStampSec) {
    return Status::Error(what + " is stamped " + std::to_string(stamp.sec) +
                         " s: beyond 2038-01-18 (" + std::to_string(kMaxInputStampSec) +
                         " s), where ROS 1 time arithmetic overflows");
  }
  // Both below 2^31 s: the difference is representable.
  if (!now.isZero() && now.sec <= kMaxInputStampSec &&
      (stamp - now).toSec() > kMaxStampAheadOfClockS) {
    char text[96];
    std::snprintf(text, sizeof(text), "%.0f s ahead of the node's clock (%u s; more than %.0f s)",
                  (stamp - now).toSec(), now.sec, kMaxStampAheadOfClockS);
    return Status::Error(what + " is stamped " + std::to_string(stamp.sec) + " s, " + text +
                         ": a broken clock");
  }
  return Status::Ok();
}

bool acceptInputStamp(const ros::Time& stamp, const std::string& what, SharedStatistics* stats,
                      bool against_clock) {
  const Status checked =
      checkInputStamp(stamp, against_clock ? ros::Time::now() : ros::Time(), what);
  if (checked) return true;
  errorThrottled("input refused: " + checked.message());
  if (stats != nullptr) stats->update([](ObjectDetectionStatistics& s) { ++s.stamps_refused; });
  return false;
}

}  // namespace mvod
