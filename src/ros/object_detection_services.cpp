#include "multiview_object_detection/ros/object_detection_services.h"

#include <set>
#include <utility>
#include <vector>

#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/io/map_folder.h"
#include "multiview_object_detection/pipeline/types/class_priors.h"
#include "multiview_object_detection/ros/map_autosaver.h"
#include "multiview_object_detection/ros/service_answering.h"

namespace mvod {

namespace {

using multiview_object_detection::GetObjects;
using multiview_object_detection::MapFile;

// Advertises `handler` so that an exception in it is logged and answered (service_answering.h).
template <typename Request, typename Response>
ros::ServiceServer advertiseAnswering(ros::NodeHandle& nh, const std::string& name,
                                      bool (ObjectDetectionServices::*handler)(Request&, Response&),
                                      ObjectDetectionServices* services) {
  const boost::function<bool(Request&, Response&)> call = [handler, services](Request& request,
                                                                              Response& response) {
    return (services->*handler)(request, response);
  };
  return nh.advertiseService<Request, Response>(name, answering(name, call));
}

}  // namespace

ObjectDetectionServices::ObjectDetectionServices(const ros::NodeHandle& nh_private,
                                                 const MapPathPolicy& map_paths,
                                                 KeyframeWorker* worker, KeyframeBuffer* buffer,
                                                 ObjectDetectionPublishers* publishers,
                                                 SharedStatistics* stats, double timeout_s)
    : map_paths_(map_paths),
      worker_(worker),
      buffer_(buffer),
      publishers_(publishers),
      stats_(stats),
      timeout_s_(timeout_s) {
  // Own queues: a long keyframe must not hold up the input callbacks, and a map change waiting for
  // it (or a long ~load_map) must not hold up the readers.
  ros::NodeHandle read_nh(nh_private);
  read_nh.setCallbackQueue(&read_queue_);
  get_objects_srv_ =
      advertiseAnswering(read_nh, "get_objects", &ObjectDetectionServices::getObjects, this);
  save_map_srv_ = advertiseAnswering(read_nh, "save_map", &ObjectDetectionServices::saveMap, this);
  ros::NodeHandle change_nh(nh_private);
  change_nh.setCallbackQueue(&change_queue_);
  load_map_srv_ =
      advertiseAnswering(change_nh, "load_map", &ObjectDetectionServices::loadMap, this);
  reset_srv_ = advertiseAnswering(change_nh, "reset", &ObjectDetectionServices::reset, this);
  refine_srv_ = advertiseAnswering(change_nh, "refine", &ObjectDetectionServices::refine, this);
  // Two threads: a long ~save_map does not hold up ~get_objects.
  read_spinner_ = std::make_unique<ros::AsyncSpinner>(2, &read_queue_);
  change_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &change_queue_);
  read_spinner_->start();
  change_spinner_->start();
}

void ObjectDetectionServices::stop() {
  read_spinner_->stop();
  change_spinner_->stop();
}

bool ObjectDetectionServices::getObjects(
    multiview_object_detection::GetObjects::Request& request,
    multiview_object_detection::GetObjects::Response& response) {
  const std::set<int> ids(request.ids.begin(), request.ids.end());
  // The COCO spelling of the class asked for ("sofa" -> "couch", as the detectors' label files
  // spell it); a name of no COCO class stays as given (a custom detector's class).
  const int coco_id = cocoClassId(request.class_name);
  const std::string class_name = coco_id < 0 ? request.class_name : cocoClassNames()[coco_id];
  const std::shared_ptr<const KeyframeWorker::MapSnapshot> map = worker_->snapshot();
  std::vector<MapObject> selected;
  bool class_known = coco_id >= 0;
  for (const MapObject& object : map->objects) {
    class_known = class_known || object.class_name == class_name;
    if (!class_name.empty() && object.class_name != class_name) continue;
    if (!ids.empty() && ids.count(object.id) == 0) continue;
    selected.push_back(object);
  }
  if (!class_name.empty() && !class_known) {
    ROS_WARN_THROTTLE(5.0,
                      "get_objects: '%s' is no COCO class name and no object of the map has it "
                      "(COCO spells e.g. \"couch\", \"dining table\", \"tv\"; see "
                      "config/class_priors.yaml)",
                      class_name.c_str());
  }
  std_msgs::Header header;
  header.frame_id = publishers_->outputFrame();
  header.stamp = ros::Time::now();
  response.objects = objectsToMsg(publishers_->inOutputFrame(selected, map->T_W_O, false), header);
  return true;
}

bool ObjectDetectionServices::saveMap(multiview_object_detection::MapFile::Request& request,
                                      multiview_object_detection::MapFile::Response& response) {
  std::string path;
  // A map is a folder <name>.mvmap: "kitchen" and "kitchen.json" are saved as kitchen.mvmap.
  Status status = resolveMapPath(mapFolderPath(request.path), map_paths_, true, &path);
  if (!status) {
    response.success = false;
    response.message = "save_map refused: " + status.message();
    ROS_ERROR("%s", response.message.c_str());
    return true;
  }
  const std::shared_ptr<const KeyframeWorker::MapSnapshot> map = worker_->snapshot();
  MapFolderWriter::Report report;
  const Status written = writeMapFile(path, *map, stats_->get().frames_received, nullptr, &report);
  response.success = written.ok();
  response.message = written ? "saved " + std::to_string(map->objects.size()) + " objects and " +
                                   std::to_string(map->history.size()) + " keyframes (" +
                                   std::to_string(report.folder_bytes) + " bytes) to " + path
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
  if (status) {
    // The folder the name stands for (kitchen.json: kitchen.mvmap), or a map file of 0.9.x.
    const std::string found = mapToLoad(path);
    if (found.empty()) {
      status = Status::Error(noMapText(path));
    }
    path = found;
  }
  if (status) status = loadMapFile(path, worker_, &loaded, timeout_s_);
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
  worker_->publishMap(ros::Time::now());
  return true;
}

bool ObjectDetectionServices::reset(std_srvs::Trigger::Request& /*request*/,
                                    std_srvs::Trigger::Response& response) {
  worker_->clearQueue();
  worker_->cancelCurrent();  // resetMap() then waits a stage at most, not a whole keyframe
  size_t removed = 0;
  const Status reset = worker_->resetMap(timeout_s_, &removed);
  if (!reset) {
    response.success = false;
    // The queue is already dropped and the keyframe in progress told to stop: only the map is kept.
    response.message = "reset: " + reset.message() +
                       " (the queued keyframes were dropped and the one in progress cancelled)";
    ROS_WARN("%s", response.message.c_str());
    return true;
  }
  buffer_->reset();
  worker_->publishMap(ros::Time::now());
  response.success = true;
  response.message =
      "map reset: " + std::to_string(removed) + " objects removed (ids keep counting)";
  ROS_INFO("%s", response.message.c_str());
  return true;
}

bool ObjectDetectionServices::refine(std_srvs::Trigger::Request& /*request*/,
                                     std_srvs::Trigger::Response& response) {
  KeyframeWorker::Refinement refinement;
  const Status refined = worker_->refine("~refine", timeout_s_, &refinement);
  if (!refined) {
    response.success = false;
    response.message = "refine: " + refined.message();
    ROS_WARN("%s", response.message.c_str());
    return true;
  }
  response.message = "refinement removed " + std::to_string(refinement.removed_atypical) +
                     " atypical and " + std::to_string(refinement.removed_intersecting) +
                     " intersecting objects; " + std::to_string(refinement.objects_left) +
                     " objects left";
  response.success = true;
  worker_->publishMap(ros::Time::now());
  return true;
}

}  // namespace mvod
