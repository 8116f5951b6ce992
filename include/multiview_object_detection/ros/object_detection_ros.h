// object_detection_node / ObjectDetectionNodelet: RGB-D frames and camera poses in; objects,
// markers, clouds and services out. A thin layer over mvod::ObjectMapper (voxblox_ros's TsdfServer
// pattern). This class only builds and wires the stages, each in its own file:
//
//   RgbdInput (sync, checks; callbacks never block)
//   -> KeyframeBuffer (pose from TF or topic, waited for without blocking; keyframe selection)
//   -> KeyframeWorker (bounded queue, oldest dropped; ONE thread: detector + ObjectMapper)
//   -> ObjectDetectionPublishers.
// NodeDiagnostics publishes /diagnostics: the map's status and one per input (silent, slow).
//
// ObjectDetectionServices run on their own callback queue and thread, so a slow keyframe does not
// stall the input.
#pragma once

#include <dynamic_reconfigure/server.h>
#include <multiview_object_detection/ObjectDetectionConfig.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "multiview_object_detection/detectors/segmenter_factory.h"
#include "multiview_object_detection/io/map_path.h"
#include "multiview_object_detection/pipeline/map/object_database.h"
#include "multiview_object_detection/ros/map_autosaver.h"
#include "multiview_object_detection/ros/object_detection_ros_config.h"
#include "multiview_object_detection/ros/object_detection_statistics.h"
#include "multiview_object_detection/ros/tf_input.h"

namespace mvod {

class DetectionsBuffer;
class KeyframeBuffer;
class KeyframePosesInput;
class KeyframeWorker;
class NodeDiagnostics;
class ObjectDetectionPublishers;
class ObjectDetectionServices;
class RgbdInput;
class RuntimeConfig;

class ObjectDetectionRos {
 public:
  using Config = ObjectDetectionRosConfig;
  using Statistics = ObjectDetectionStatistics;

  // Reads every parameter from nh_private (ros_params.h). Check ok(): with invalid parameters, a
  // missing model or an unreadable priors file the node reports the reason (ROS_ERROR) and stays
  // inert.
  ObjectDetectionRos(const ros::NodeHandle& nh, const ros::NodeHandle& nh_private);
  // Configured in code (tests): no parameter server needed for the configuration. `segmenter`, if
  // given, replaces the detector the config names (not used with detector "topic").
  ObjectDetectionRos(const ros::NodeHandle& nh, const ros::NodeHandle& nh_private,
                     const Config& config, std::unique_ptr<InstanceSegmenter> segmenter = nullptr);
  ~ObjectDetectionRos();

  ObjectDetectionRos(const ObjectDetectionRos&) = delete;
  ObjectDetectionRos& operator=(const ObjectDetectionRos&) = delete;

  bool ok() const { return ok_; }
  // Why the node did not start (empty when ok()).
  const std::string& startupError() const { return startup_error_; }

  // Stops the worker without waiting for the work in hand (the keyframe in progress is cancelled
  // between its stages, the queue dropped), refines the map (Sec. 3.5), publishes it once more
  // while ROS is up, and autosaves it. Idempotent; the destructor calls it.
  void shutdown();

  std::vector<MapObject> objects() const;
  Statistics statistics() const;
  Config config() const;

 private:
  using ReconfigureServer =
      dynamic_reconfigure::Server<multiview_object_detection::ObjectDetectionConfig>;

  void start(std::unique_ptr<InstanceSegmenter> segmenter);
  // start()'s steps. The parameters' check, the class priors and the detector (false: failed,
  // fail() called); an injected segmenter is kept.
  bool checkAndLoad(const Config& config, ClassPriors* priors,
                    std::unique_ptr<InstanceSegmenter>* segmenter, bool* segmenter_injected);
  void logStart(const Config& config, const InstanceSegmenter* segmenter) const;
  // The stages, each told only about the ones it hands work to.
  void createStages(const Config& config, const ClassPriors& priors,
                    std::unique_ptr<InstanceSegmenter> segmenter, bool segmenter_injected);
  // map_directory and the autosaver (false: failed, fail() called).
  bool setUpMapFiles(const Config& config, const MapPathPolicy& map_paths);
  // Dynamic reconfigure, from the values in effect (not the .cfg defaults).
  void startReconfigure();
  // The worker, the autosaver, the TF listener, the subscriptions and the diagnostics.
  void startThreads(const Config& config);
  void fail(const std::string& message);
  // load_map_on_start: the map file into the worker (a missing one is a first run, an unreadable
  // one is moved aside; neither stops the node).
  void loadMapOnStart(const Config& config, const MapPathPolicy& paths);
  void reconfigureCallback(multiview_object_detection::ObjectDetectionConfig& rc, uint32_t level);

  ros::NodeHandle nh_;
  ros::NodeHandle nh_private_;
  bool ok_ = false;
  std::string startup_error_;
  // Set first in shutdown(): the stages ignore new input from then on.
  std::atomic<bool> shut_down_{false};

  // Declared so that a stage is destroyed before the stages it calls; without ok() only stats_
  // and config_ exist.
  SharedStatistics stats_;
  std::unique_ptr<RuntimeConfig> config_;
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<TfStampCheck> tf_stamp_check_;  // pose_source tf only
  std::unique_ptr<TfInput> tf_input_;
  std::unique_ptr<ObjectDetectionPublishers> publishers_;
  std::unique_ptr<DetectionsBuffer> detections_;  // detector "topic" only
  std::unique_ptr<KeyframeWorker> worker_;
  std::unique_ptr<KeyframeBuffer> buffer_;
  std::unique_ptr<KeyframePosesInput> keyframe_poses_;
  std::unique_ptr<RgbdInput> input_;
  std::unique_ptr<ObjectDetectionServices> services_;
  std::unique_ptr<NodeDiagnostics> diagnostics_;
  std::unique_ptr<MapAutosaver> autosaver_;  // autosave_period_s > 0 only
  boost::recursive_mutex reconfigure_mutex_;
  std::unique_ptr<ReconfigureServer> reconfigure_server_;
};

}  // namespace mvod
