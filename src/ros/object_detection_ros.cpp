#include "multiview_object_detection/ros/object_detection_ros.h"

#include <fcntl.h>
#include <sys/stat.h>

#include <boost/bind/bind.hpp>
#include <cerrno>
#include <cstdio>
#include <ctime>
#include <deque>
#include <map>
#include <utility>

#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/io/map_folder.h"
#include "multiview_object_detection/pipeline/types/class_priors.h"
#include "multiview_object_detection/ros/detections_buffer.h"
#include "multiview_object_detection/ros/keyframe_buffer.h"
#include "multiview_object_detection/ros/keyframe_poses_input.h"
#include "multiview_object_detection/ros/keyframe_worker.h"
#include "multiview_object_detection/ros/node_diagnostics.h"
#include "multiview_object_detection/ros/object_detection_publishers.h"
#include "multiview_object_detection/ros/object_detection_services.h"
#include "multiview_object_detection/ros/reconfigure_names.h"
#include "multiview_object_detection/ros/rgbd_input.h"
#include "multiview_object_detection/ros/ros_params.h"
#include "multiview_object_detection/ros/runtime_config.h"
#include "multiview_object_detection/ros/standard_messages.h"

namespace mvod {

ObjectDetectionRos::ObjectDetectionRos(const ros::NodeHandle& nh, const ros::NodeHandle& nh_private)
    : nh_(nh), nh_private_(nh_private) {
  std::vector<std::string> errors;
  config_ =
      std::make_unique<RuntimeConfig>(getObjectDetectionConfigFromRosParam(nh_private_, &errors));
  if (!errors.empty()) {
    std::string text = "invalid parameters in " + nh_private_.getNamespace() + ":";
    for (const std::string& error : errors) text += "\n  " + error;
    fail(text);
    return;
  }
  start(nullptr);
}

ObjectDetectionRos::ObjectDetectionRos(const ros::NodeHandle& nh, const ros::NodeHandle& nh_private,
                                       const Config& config,
                                       std::unique_ptr<InstanceSegmenter> segmenter)
    : nh_(nh), nh_private_(nh_private), config_(std::make_unique<RuntimeConfig>(config)) {
  start(std::move(segmenter));
}

ObjectDetectionRos::~ObjectDetectionRos() { shutdown(); }

void ObjectDetectionRos::fail(const std::string& message) {
  ok_ = false;
  startup_error_ = message;
  ROS_ERROR("object detection does not start: %s", message.c_str());
}

void ObjectDetectionRos::start(std::unique_ptr<InstanceSegmenter> segmenter) {
  const Config config = config_->get();
  ClassPriors priors;
  bool segmenter_injected = false;
  if (!checkAndLoad(config, &priors, &segmenter, &segmenter_injected)) return;
  ok_ = true;
  logStart(config, segmenter.get());
  createStages(config, priors, std::move(segmenter), segmenter_injected);
  const MapPathPolicy map_paths{config.map_directory, config.allow_any_map_path};
  if (!setUpMapFiles(config, map_paths)) return;
  if (!config.load_map_on_start.empty()) loadMapOnStart(config, map_paths);
  // Advertised once the map is loaded: their threads answer at once, and ~get_objects must not
  // answer an empty map while load_map_on_start is still reading the file.
  services_ = std::make_unique<ObjectDetectionServices>(nh_private_, map_paths, worker_.get(),
                                                        buffer_.get(), publishers_.get(), &stats_,
                                                        config.service_timeout_s);
  // The output frame's TF from the start (a loaded map's, or that of the configured gravity).
  publishers_->publishOutputFrame(worker_->snapshot()->T_W_O);
  startReconfigure();
  startThreads(config);
}

bool ObjectDetectionRos::checkAndLoad(const Config& config, ClassPriors* priors,
                                      std::unique_ptr<InstanceSegmenter>* segmenter,
                                      bool* segmenter_injected) {
  const Status valid = config.isValid();
  if (!valid) {
    fail("invalid parameter in " + nh_private_.getNamespace() + ": " + valid.message());
    return false;
  }
  if (config.priors_file.empty()) {
    fail("priors_file is not set and the package's config/class_priors.yaml was not found");
    return false;
  }
  const Status loaded = ClassPriors::loadYaml(config.priors_file, priors);
  if (!loaded) {
    fail("cannot load the class priors (priors_file): " + loaded.message());
    return false;
  }
  *segmenter_injected = false;
  if (config.detector != "topic") {
    if (*segmenter) {
      *segmenter_injected = true;
    } else {
      const Status created = createInstanceSegmenter(config.segmenterOptions(), segmenter);
      if (!created) {
        const SegmenterOptions options = config.segmenterOptions();
        const std::string chosen = config.detector_auto
                                       ? "detector 'auto' (it looks for YOLOv5n-seg first, " +
                                             resolveModelPath(options, options.yolo_seg_model) +
                                             ": not there, so " + config.detector + ")"
                                       : "detector '" + config.detector + "'";
        fail(chosen + ": " + created.message());
        return false;
      }
    }
  } else {
    segmenter->reset();  // detections come from the topic
  }
  return true;
}

void ObjectDetectionRos::logStart(const Config& config, const InstanceSegmenter* segmenter) const {
  // One line; every setting at DEBUG (rosconsole), as voxblox_ros and pcl_ros do. "Other than the
  // defaults": than what the node makes of no parameters at all (read from a namespace that holds
  // none), so the detector 'auto' chose, its thresholds and the resolved folders are not listed.
  Config defaults =
      getObjectDetectionConfigFromRosParam(ros::NodeHandle(nh_private_, "__no_parameters__"));
  defaults.autosave_path = defaultAutosaveName(nh_private_.getNamespace());
  const std::string changes = config.printChanges(defaults);
  ROS_INFO_STREAM("object detection: "
                  << (segmenter != nullptr ? segmenter->name() : "detections topic") << ", priors "
                  << config.priors_file << "; settings other than the defaults: "
                  << (changes.empty() ? std::string("none") : changes)
                  << " (all of them at DEBUG); standard messages: "
                  << (publishesVisionMsgs() ? "~detections_3d" : "")
                  << (publishesJskRecognitionMsgs() ? " ~bounding_boxes" : "")
                  << (publishesVisionMsgs() || publishesJskRecognitionMsgs()
                          ? ""
                          : "none (built without vision_msgs and "
                            "jsk_recognition_msgs)"));
  ROS_DEBUG_STREAM("object detection settings:\n" << config.print());
}

void ObjectDetectionRos::createStages(const Config& config, const ClassPriors& priors,
                                      std::unique_ptr<InstanceSegmenter> segmenter,
                                      bool segmenter_injected) {
  input_ = std::make_unique<RgbdInput>(nh_, nh_private_, config, &stats_, shut_down_);
  publishers_ = std::make_unique<ObjectDetectionPublishers>(nh_, nh_private_, config, &stats_);
  diagnostics_ =
      std::make_unique<NodeDiagnostics>(nh_, nh_private_, &stats_, config.diagnostic_period);
  tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
  if (config.detector == "topic")
    detections_ = std::make_unique<DetectionsBuffer>(shut_down_, &stats_);
  worker_ = std::make_unique<KeyframeWorker>(priors, std::move(segmenter), segmenter_injected,
                                             input_->topics(), config_.get(), *tf_buffer_,
                                             detections_.get(), publishers_.get(), &stats_);
  buffer_ = std::make_unique<KeyframeBuffer>(
      config, input_->topics(), *tf_buffer_, publishers_.get(), &stats_, shut_down_,
      [this](KeyframeJob job) { worker_->enqueue(std::move(job)); });
  keyframe_poses_ =
      std::make_unique<KeyframePosesInput>(config.world_frame, *tf_buffer_, &stats_, shut_down_,
                                           [this](std::vector<PoseCorrection> corrections) {
                                             worker_->enqueueCorrections(std::move(corrections));
                                           });
  if (detections_) {
    buffer_->setTimeJumpCallback([this](const ros::Time& stamp) { detections_->dropAfter(stamp); });
  }
}

bool ObjectDetectionRos::setUpMapFiles(const Config& config, const MapPathPolicy& map_paths) {
  const Status writable = prepareMapDirectory(map_paths);
  if (!writable && config.autosave_period_s > 0.0) {
    fail(writable.message() +
         " (set map_directory to a writable folder, or autosave_period_s 0 to run without saving)");
    return false;
  }
  if (!writable) ROS_WARN("%s: ~save_map will fail", writable.message().c_str());
  if (config.autosave_period_s > 0.0) {
    std::string autosave_path;
    const std::string name = config.autosave_path.empty()
                                 ? defaultAutosaveName(nh_private_.getNamespace())
                                 : config.autosave_path;
    const Status resolved = resolveMapPath(mapFolderPath(name), map_paths, true, &autosave_path);
    if (!resolved) {
      fail("autosave_path: " + resolved.message() + " (autosave_period_s 0 turns autosave off)");
      return false;
    }
    autosaver_ = std::make_unique<MapAutosaver>(autosave_path, config.autosave_period_s,
                                                worker_.get(), &stats_);
  }
  return true;
}

void ObjectDetectionRos::startReconfigure() {
  reconfigure_server_ = std::make_unique<ReconfigureServer>(reconfigure_mutex_, nh_private_);
  {
    multiview_object_detection::ObjectDetectionConfig rc = config_->reconfigureValues();
    boost::recursive_mutex::scoped_lock lock(reconfigure_mutex_);
    reconfigure_server_->updateConfig(rc);
  }
  reconfigure_server_->setCallback(boost::bind(&ObjectDetectionRos::reconfigureCallback, this,
                                               boost::placeholders::_1, boost::placeholders::_2));
}

void ObjectDetectionRos::startThreads(const Config& config) {
  worker_->start();
  if (autosaver_) {
    autosaver_->start();
    ROS_INFO("autosave: every %.0f s to %s", config.autosave_period_s, autosaver_->path().c_str());
  }
  if (config.pose_source == "tf")
    tf_stamp_check_ = std::make_unique<TfStampCheck>(config.world_frame);
  tf_input_ = std::make_unique<TfInput>(tf_buffer_.get(), &stats_, tf_stamp_check_.get());
  tf_input_->start(nh_);
  // The stale and rate checks count from here.
  stats_.inputs().configure({config.input_min_rate_hz, config.input_timeout_s});
  input_->subscribe([this](PendingFrame frame) {
    if (tf_stamp_check_ && frame.msgs.color) {
      tf_stamp_check_->addImage(frame.msgs.color->header.stamp.toSec());
    }
    buffer_->addFrame(std::move(frame));
  });
  if (detections_) detections_->subscribe(nh_);
  keyframe_poses_->subscribe(nh_);
  buffer_->start(nh_);
  diagnostics_->start();
}

void ObjectDetectionRos::loadMapOnStart(const Config& config, const MapPathPolicy& paths) {
  std::string requested;
  Status status = resolveMapPath(config.load_map_on_start, paths, false, &requested);
  if (!status) {
    ROS_ERROR("load_map_on_start: %s; starting with an empty map", status.message().c_str());
    return;
  }
  // The folder the name stands for, or a map file of 0.9.x, whichever was written last.
  const std::string path = mapToLoad(requested);
  if (path.empty()) {
    ROS_INFO("load_map_on_start: %s; starting with an empty map", noMapText(requested).c_str());
    return;
  }
  size_t objects = 0;
  std::map<int, std::string> keyframe_files;
  status = loadMapFile(path, worker_.get(), &objects, -1.0, &keyframe_files);
  if (status) {
    ROS_INFO("load_map_on_start: resumed %zu objects from %s", objects, path.c_str());
    if (autosaver_) autosaver_->adoptLoadedMap(path, keyframe_files);
    worker_->publishMap(ros::Time::now());
    return;
  }
  // Kept for a person to look at, and out of the autosave's way (a map folder as a whole). A link
  // is never moved (nor what it points to); RENAME_NOREPLACE: nothing already at the new name is
  // replaced.
  const std::string aside = path + ".unreadable-" + std::to_string(std::time(nullptr));
  struct stat info {};
  const bool link = ::lstat(path.c_str(), &info) == 0 && S_ISLNK(info.st_mode);
  const bool moved =
      !link && ::renameat2(AT_FDCWD, path.c_str(), AT_FDCWD, aside.c_str(), RENAME_NOREPLACE) == 0;
  ROS_ERROR("load_map_on_start: cannot load %s: %s; %s; starting with an empty map", path.c_str(),
            status.message().c_str(),
            moved  ? ("it is kept as " + aside).c_str()
            : link ? "it is a symbolic link, left as it is"
                   : "it could not be moved aside");
}

void ObjectDetectionRos::reconfigureCallback(multiview_object_detection::ObjectDetectionConfig& rc,
                                             uint32_t /*level*/) {
  KeyframeSelector::Config keyframes;
  if (!config_->reconfigure(&rc, &keyframes)) return;
  setYamlParameters(nh_private_, rc);  // the live value under the YAML name too
  // After the config's lock is released: the input stage takes the buffer's lock first.
  buffer_->setKeyframeConfig(keyframes);
}

void ObjectDetectionRos::shutdown() {
  if (!ok_ || shut_down_.exchange(true)) return;
  // No new input.
  buffer_->stop();
  diagnostics_->stop();
  input_->unsubscribe();
  keyframe_poses_->unsubscribe();
  // Within a stage's time: the keyframe in progress is cancelled and the queue dropped (the map is
  // that of the last finished keyframe, and the autosave's).
  worker_->stopNow();
  if (detections_) detections_->unsubscribe();

  // Sec. 3.5 on the final map.
  KeyframeWorker::Refinement refinement;
  worker_->refine("shutdown", -1.0, &refinement);  // the worker has stopped: nothing to wait for
  if (ros::ok()) worker_->publishMap(ros::Time::now());
  if (autosaver_) autosaver_->stop();  // the final map, refined
  if (services_) services_->stop();
  ROS_INFO("object detection stopped: %d keyframes processed, %zu objects in the map",
           statistics().keyframes_processed, objects().size());
}

std::vector<MapObject> ObjectDetectionRos::objects() const {
  if (!worker_) return {};
  return worker_->objects();
}

ObjectDetectionRos::Statistics ObjectDetectionRos::statistics() const { return stats_.get(); }

ObjectDetectionRos::Config ObjectDetectionRos::config() const { return config_->get(); }

}  // namespace mvod
