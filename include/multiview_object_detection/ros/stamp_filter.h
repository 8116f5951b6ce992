// A message_filters stage in front of the RGB-D synchroniser: a message whose stamp the
// synchroniser's time arithmetic cannot hold (checkInputStamp) is refused here, and no exception
// of what follows it (synchroniser, frame checks) leaves the callback. A stamp earlier than the
// last one passed on (a bag played again, a clock reset) is reported to onJumpBack first, so that
// the synchroniser can start afresh rather than hold the old stream's messages against the new.
#pragma once

#include <message_filters/simple_filter.h>
#include <ros/message_event.h>

#include <boost/bind/bind.hpp>
#include <functional>
#include <string>

#include "multiview_object_detection/ros/input_guard.h"

namespace mvod {

template <class M>
class StampFilter : public message_filters::SimpleFilter<M> {
 public:
  using EventType = ros::MessageEvent<M const>;

  StampFilter(std::string topic, SharedStatistics* stats)
      : topic_(std::move(topic)), stats_(stats) {}

  template <class F>
  void connectInput(F& input) {
    connection_.disconnect();
    connection_ = input.registerCallback(typename message_filters::SimpleFilter<M>::EventCallback(
        boost::bind(&StampFilter::add, this, boost::placeholders::_1)));
  }

  void disconnect() { connection_.disconnect(); }

  // Called (on the callback thread, before the message goes on) with the topic, the last stamp
  // passed on and the earlier one that came now.
  using JumpBackCallback =
      std::function<void(const std::string& topic, const ros::Time& last, const ros::Time& now)>;
  void onJumpBack(JumpBackCallback callback) { on_jump_back_ = std::move(callback); }
  // Forgets the last stamp: the next message is not compared with the old stream's.
  void forgetLastStamp() { last_stamp_ = ros::Time(); }

 private:
  void add(const EventType& event) {
    if (stats_ != nullptr) stats_->inputs().received(topic_);
    runGuarded("input '" + topic_ + "'", stats_, [&] {
      const ros::Time& stamp = event.getMessage()->header.stamp;
      if (!acceptInputStamp(stamp, "message on '" + topic_ + "'", stats_)) return;
      if (!last_stamp_.isZero() && stamp < last_stamp_ && on_jump_back_) {
        const ros::Time last = last_stamp_;
        on_jump_back_(topic_, last, stamp);
      }
      last_stamp_ = stamp;
      this->signalMessage(event);
    });
  }

  JumpBackCallback on_jump_back_;
  ros::Time last_stamp_;
  std::string topic_;
  SharedStatistics* stats_;
  message_filters::Connection connection_;
};

}  // namespace mvod
