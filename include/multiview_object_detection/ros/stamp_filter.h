// A message_filters stage in front of the RGB-D synchroniser: a message whose stamp the
// synchroniser's time arithmetic cannot hold (checkInputStamp) is refused here, and no exception
// of what follows it (synchroniser, frame checks) leaves the callback.
#pragma once

#include <message_filters/simple_filter.h>
#include <ros/message_event.h>

#include <boost/bind/bind.hpp>
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

 private:
  void add(const EventType& event) {
    if (stats_ != nullptr) stats_->inputs().received(topic_);
    runGuarded("input '" + topic_ + "'", stats_, [&] {
      if (!acceptInputStamp(event.getMessage()->header.stamp, "message on '" + topic_ + "'",
                            stats_)) {
        return;
      }
      this->signalMessage(event);
    });
  }

  std::string topic_;
  SharedStatistics* stats_;
  message_filters::Connection connection_;
};

}  // namespace mvod
