// The node's services: ~get_objects, ~save_map, ~load_map, ~reset and ~refine. They run on their
// own callback queues and threads, so a slow keyframe does not stall the input callbacks. Reading
// the map (~get_objects, ~save_map) has a queue of its own and answers from the last snapshot, also
// while ~load_map parses a file; changing it (~load_map, ~reset, ~refine) waits for the keyframe in
// progress at most service_timeout_s, then answers "busy". Map files lie in map_directory.
#pragma once

#include <multiview_object_detection/GetObjects.h>
#include <multiview_object_detection/MapFile.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>

#include <memory>
#include <string>

#include "multiview_object_detection/io/map_path.h"
#include "multiview_object_detection/ros/keyframe_buffer.h"
#include "multiview_object_detection/ros/keyframe_worker.h"
#include "multiview_object_detection/ros/object_detection_publishers.h"
#include "multiview_object_detection/ros/object_detection_statistics.h"

namespace mvod {

class ObjectDetectionServices {
 public:
  // Advertises the services in nh_private's namespace and starts their thread.
  ObjectDetectionServices(const ros::NodeHandle& nh_private, const MapPathPolicy& map_paths,
                          KeyframeWorker* worker, KeyframeBuffer* buffer,
                          ObjectDetectionPublishers* publishers, SharedStatistics* stats,
                          double timeout_s);

  ObjectDetectionServices(const ObjectDetectionServices&) = delete;
  ObjectDetectionServices& operator=(const ObjectDetectionServices&) = delete;

  void stop();

 private:
  bool getObjects(multiview_object_detection::GetObjects::Request& request,
                  multiview_object_detection::GetObjects::Response& response);
  bool saveMap(multiview_object_detection::MapFile::Request& request,
               multiview_object_detection::MapFile::Response& response);
  bool loadMap(multiview_object_detection::MapFile::Request& request,
               multiview_object_detection::MapFile::Response& response);
  bool reset(std_srvs::Trigger::Request& request, std_srvs::Trigger::Response& response);
  bool refine(std_srvs::Trigger::Request& request, std_srvs::Trigger::Response& response);

  const MapPathPolicy map_paths_;
  KeyframeWorker* worker_;
  KeyframeBuffer* buffer_;
  ObjectDetectionPublishers* publishers_;
  SharedStatistics* stats_;
  const double timeout_s_;  // service_timeout_s

  ros::CallbackQueue read_queue_;    // ~get_objects, ~save_map
  ros::CallbackQueue change_queue_;  // ~load_map, ~reset, ~refine
  std::unique_ptr<ros::AsyncSpinner> read_spinner_;
  std::unique_ptr<ros::AsyncSpinner> change_spinner_;
  ros::ServiceServer get_objects_srv_;
  ros::ServiceServer save_map_srv_;
  ros::ServiceServer load_map_srv_;
  ros::ServiceServer reset_srv_;
  ros::ServiceServer refine_srv_;
};

}  // namespace mvod
