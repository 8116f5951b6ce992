#include "multiview_object_detection/ros/object_detection_services.h"

#include <set>
#include <utility>
#include <vector>

#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/ros/map_autosaver.h"

namespace mvod {

ObjectDetectionServices::ObjectDetectionServices(const ros::NodeHandle& nh_private,
                                                 const std::string& world_frame,
                                                 const MapPathPolicy& map_paths,
                                                 KeyframeWorker* worker, KeyframeBuffer* buffer,
                                                 ObjectDetectionPublishers* publishers,
                                                 SharedStatistics* stats)
    : world_frame_(world_frame),
      map_paths_(map_paths),
      worker_(worker),
      buffer_(buffer),
      publishers_(publishers),
      stats_(stats) {
  // Own queue: a long keyframe must not hold up the input callbacks.
  ros::NodeHandle service_nh(nh_private);
  service_nh.setCallbackQueue(&queue_);
  get_objects_srv_ =
      service_nh.advertiseService("get_objects", &ObjectDetectionServices::getObjects, this);
  save_map_srv_ = service_nh.advertiseService("save_map", &ObjectDetectionServices::saveMap, this);
  load_map_srv_ = service_nh.advertiseService("load_map", &ObjectDetectionServices::loadMap, this);
  reset_srv_ = service_nh.advertiseService("reset", &ObjectDetectionServices::reset, this);
  refine_srv_ = service_nh.advertiseService("refine", &ObjectDetectionServices::refine, this);
  spinner_ = std::make_unique<ros::AsyncSpinner>(1, &queue_);
  spinner_->start();
}

void ObjectDetectionServices::stop() { spinner_->stop(); }

bool ObjectDetectionServices::getObjects(
    multiview_object_detection::GetObjects::Request& request,
    multiview_object_detection::GetObjects::Response& response) {
  const std::set<int> ids(request.ids.begin(), request.ids.end());
  std::vector<MapObject> selected;
  for (MapObject& object : worker_->objects()) {
    if (!request.class_name.empty() && object.class_name != request.class_name) continue;
    if (!ids.empty() && ids.count(object.id) == 0) continue;
    selected.push_back(std::move(object));
  }
  std_msgs::Header header;
  header.frame_id = world_frame_;
  header.stamp = ros::Time::now();
  response.objects = objectsToMsg(selected, header);
  return true;
}

bool ObjectDetectionServices::saveMap(multiview_object_detection::MapFile::Request& request,
                                      multiview_object_detection::MapFile::Response& response) {
  std::string path;
  Status status = resolveMapPath(request.path, map_paths_, true, &path);
  if (!status) {
    response.success = false;
    response.message = "save_map refused: " + status.message();
    ROS_ERROR("%s", response.message.c_str());
    return true;
  }
  const std::shared_ptr<const KeyframeWorker::MapSnapshot> map = worker_->snapshot();
  const Status written = writeMapFile(path, *map, stats_->get().frames_received);
  response.success = written.ok();
  response.message = written
                         ? "saved " + std::to_string(map->objects.size()) + " objects to " + path
                         : "save_map: " + written.message();
  if (written) {
    ROS_INFO("%s", response.message.c_str());
  } else {
    ROS_ERROR("%s", response.message.c_str());
  }
  return true;
}

bool ObjectDetectionServices::loadMap(multiview_object_detection::MapFile::Request& request,
                                      multiview_object_detection::MapFile::Response& response) {
  std::string path;
  size_t loaded = 0;
  Status status = resolveMapPath(request.path, map_paths_, false, &path);
  if (status) status = loadMapFile(path, worker_, &loaded);
  if (!status) {
    response.success = false;
    response.message = "load_map refused '" + request.path + "': " + status.message() +
                       "; the current map (" + std::to_string(worker_->snapshot()->objects.size()) +
                       " objects) is kept";
    ROS_ERROR("%s", response.message.c_str());
    return true;
  }
  response.success = true;
  response.message = "loaded " + std::to_string(loaded) + " objects from " + path;
  ROS_INFO("%s", response.message.c_str());
  publishers_->publishMap(worker_->objects(), ros::Time::now());
  return true;
}

bool ObjectDetectionServices::reset(std_srvs::Trigger::Request& /*request*/,
                                    std_srvs::Trigger::Response& response) {
  worker_->clearQueue();
  worker_->cancelCurrent();  // resetMap() then waits a stage at most, not a whole keyframe
  const size_t removed = worker_->resetMap();
  buffer_->reset();
  publishers_->publishMap(worker_->objects(), ros::Time::now());
  response.success = true;
  response.message =
      "map reset: " + std::to_string(removed) + " objects removed (ids keep counting)";
  ROS_INFO("%s", response.message.c_str());
  return true;
}

bool ObjectDetectionServices::refine(std_srvs::Trigger::Request& /*request*/,
                                     std_srvs::Trigger::Response& response) {
  const KeyframeWorker::Refinement refinement = worker_->refine("~refine");
  response.message = "refinement removed " + std::to_string(refinement.removed_atypical) +
                     " atypical and " + std::to_string(refinement.removed_intersecting) +
                     " intersecting objects; " + std::to_string(refinement.objects_left) +
                     " objects left";
  response.success = true;
  publishers_->publishMap(worker_->objects(), ros::Time::now());
  return true;
}

}  // namespace mvod
