// What stands between untrusted messages and the node: stamps that ROS 1 time arithmetic cannot
// hold are refused before any of it runs, and no exception of a callback ends the process.
#pragma once

#include <ros/time.h>

#include <boost/function.hpp>
#include <boost/shared_ptr.hpp>
#include <cstdint>
#include <exception>
#include <string>

#include "multiview_object_detection/pipeline/types/common.h"
#include "multiview_object_detection/ros/object_detection_statistics.h"
#include "multiview_object_detection/ros/throttled_log.h"

namespace mvod {

// ros::Time holds unsigned 32-bit seconds and ros::Duration signed 32-bit seconds: the difference
// of two stamps throws once they are more than 2^31 - 1 s apart, and stamp + duration once the sum
// passes 2^32 - 1. Stamps below this (2038-01-18, one day short of 2^31 s) keep every difference
// and every offset the node takes (at most hours) representable.
constexpr std::uint32_t kMaxInputStampSec = 2147483647u - 86400u;
// A stamp this far ahead of the node's clock (ros::Time::now(), wall or sim time) is a broken
// clock, not a frame: accepted, it would make every later frame look like a jump back in time.
constexpr double kMaxStampAheadOfClockS = 3600.0;
// A stamp this much older than the newest seen on an input means time jumped back (a bag
// restarted, a clock reset, or the newest was a bogus future stamp): what was buffered for the
// abandoned timeline is dropped (keyframe and detections buffers). Smaller steps back are
// out-of-order input and are refused.
constexpr double kTimeJumpBackS = 1.0;

// "sec.nsec" with nine decimals, as a log line names a stamp.
std::string stampText(const ros::Time& stamp);

// Ok, or why `stamp` is refused; `what` names the input (topic as remapped, or TF frames). `now` is
// the node's clock; zero (sim time before the first /clock) skips the clock check.
Status checkInputStamp(const ros::Time& stamp, const ros::Time& now, const std::string& what);

// True if `stamp` may go on; else the refusal is logged (throttled) and counted ("stamps refused").
// `against_clock` false: only the 2038 limit (a static transform, whose stamp look-ups ignore: a
// static_transform_publisher on the wall clock beside a node on a bag's clock is fine).
bool acceptInputStamp(const ros::Time& stamp, const std::string& what, SharedStatistics* stats,
                      bool against_clock = true);

// Runs `body`, a callback's work. An exception it throws is logged (throttled, naming `what`),
// counted on /diagnostics ("callback exceptions"), and the node goes on.
template <typename Body>
void runGuarded(const std::string& what, SharedStatistics* stats, Body&& body) noexcept {
  std::string error;
  try {
    body();
    return;
  } catch (const std::exception& e) {
    error = e.what();
  } catch (...) {
    error = "an exception that is not a std::exception";
  }
  errorThrottled(what + ": failed with an exception, input dropped, the node goes on: " + error);
  if (stats != nullptr) {
    stats->update([](ObjectDetectionStatistics& s) { ++s.callback_exceptions; });
  }
}

// A roscpp callback for a message with a header: a stamp checkInputStamp refuses is logged
// (throttled, naming `topic`) and counted; the rest goes to `handler`, run guarded.
template <class Msg, class Handler>
boost::function<void(const boost::shared_ptr<const Msg>&)> guardedCallback(const std::string& topic,
                                                                           SharedStatistics* stats,
                                                                           Handler handler) {
  return [topic, stats, handler](const boost::shared_ptr<const Msg>& msg) {
    if (stats != nullptr) stats->inputs().received(topic);
    runGuarded("input '" + topic + "'", stats, [&] {
      if (!acceptInputStamp(msg->header.stamp, "message on '" + topic + "'", stats)) return;
      handler(msg);
    });
  };
}

}  // namespace mvod
