// A service handler that answers its own exceptions: logged, and answered success false with the
// exception's text where the response has a message. roscpp's own answer to an exception is a
// failed call the caller reads nothing from.
#pragma once

#include <multiview_object_detection/GetObjects.h>
#include <multiview_object_detection/MapFile.h>
#include <ros/console.h>
#include <std_srvs/Trigger.h>

#include <boost/function.hpp>
#include <exception>
#include <string>

namespace mvod {

// What a service answers when its handler threw: success false and why. ~get_objects has no
// message: its call fails, as an empty answer would say "no objects".
inline bool answerFailure(const std::string& text,
                          multiview_object_detection::MapFile::Response* response) {
  response->success = false;
  response->message = text;
  return true;
}
inline bool answerFailure(const std::string& text, std_srvs::Trigger::Response* response) {
  response->success = false;
  response->message = text;
  return true;
}
inline bool answerFailure(const std::string& /*text*/,
                          multiview_object_detection::GetObjects::Response* /*response*/) {
  return false;
}

// `handler` wrapped for advertiseService: an exception in it is logged ("<name> failed: <what>")
// and answered by answerFailure, and the node goes on.
template <typename Request, typename Response>
boost::function<bool(Request&, Response&)> answering(
    const std::string& name, const boost::function<bool(Request&, Response&)>& handler) {
  return [name, handler](Request& request, Response& response) {
    try {
      return handler(request, response);
    } catch (const std::exception& error) {
      const std::string text = name + " failed: " + error.what();
      ROS_ERROR("%s", text.c_str());
      return answerFailure(text, &response);
    }
  };
}

}  // namespace mvod
