// Everything ObjectDetectionRos is configured with: the node's own settings, the detector's and the
// core's. Defaults in code; ros_params.h fills it from the parameter server, tests fill it
// directly.
#pragma once

#include <string>

#include "multiview_object_detection/detectors/segmenter_factory.h"
#include "multiview_object_detection/pipeline/object_mapper.h"
#include "multiview_object_detection/pipeline/stages/keyframe_selector.h"

namespace mvod {

struct ObjectDetectionRosConfig {
  // Frames.
  std::string world_frame = "map";
  // Frame of every output (objects, markers, clouds, services): the gravity-aligned frame, z up,
  // origin on the floor under world_frame's origin, published as TF world_frame -> output_frame
  // (output_frame.h). Equal to world_frame (or empty): outputs in world_frame, no TF.
  std::string output_frame = "map_gravity_aligned";
  bool publishesOutputFrame() const { return !output_frame.empty() && output_frame != world_frame; }
  const std::string& outputFrame() const {
    return publishesOutputFrame() ? output_frame : world_frame;
  }
  std::string camera_frame;  // empty = the colour image's header.frame_id

  // RGB-D input (message_filters).
  bool depth_registered = true;  // false: depth/image_raw + depth/camera_info, T_C_D from TF
  int queue_size = 10;
  bool exact_sync = false;
  // /diagnostics: an input (images, camera_info, pose topic) slower than this is a warning, and
  // any input silent for input_timeout_s (or since the start) is an error naming the topic.
  double input_min_rate_hz = 1.0;
  double input_timeout_s = 5.0;
  // Seconds between /diagnostics messages (diagnostic_updater's parameter name). make demo's player
  // sets it short to pace the bag on what the node received.
  double diagnostic_period = 1.0;

  // Camera pose: "tf" (world_frame <- camera frame at the image stamp) or "topic" (PoseStamped).
  std::string pose_source = "tf";
  // How long a frame waits for its pose (TF or pose topic) and, with keyframe_mode topic, for its
  // keyframe message (s).
  double tf_timeout_s = 0.1;
  // pose_source topic: the nearest pose within this time of the image stamp is used (s).
  double pose_max_time_diff_s = 0.05;

  // Gravity: "param" (gravity_down_W below), "tf" (-z of gravity_frame in world_frame) or
  // "estimate" (GravityEstimator: the surfaces in view).
  std::string gravity_source = "param";
  Eigen::Vector3d gravity_down_W = Eigen::Vector3d(0, 0, -1);
  std::string gravity_frame = "base_link";

  KeyframeSelector::Config keyframes;

  // "yolo_seg" | "fastestdet" | "maskrcnn" (OpenCV DNN in this node, options in `segmenter`) |
  // "topic" (InstanceDetections on `detections`, matched by stamp). The parameter's "auto"
  // (its default) is resolved by ros_params: yolo_seg where its model file is found, else
  // fastestdet.
  std::string detector = "fastestdet";
  // The detector parameter was "auto" (and `detector` is what it chose): a start-up failure says
  // so.
  bool detector_auto = false;
  SegmenterOptions segmenter;
  double detections_max_age_s =
      1.0;  // detector topic: how long a keyframe waits for its detections
  // Of more detections in one frame, the highest-scoring are used (any detector); bounds the
  // memory and time one frame can cost.
  int max_detections_per_frame = 100;

  // ~save_map / ~load_map: relative paths resolve into map_directory, and absolute paths must lie
  // in it, unless allow_any_map_path. Empty = $ROS_HOME/multiview_object_detection/maps
  // (~/.ros/...); ros_params fills it in.
  std::string map_directory;
  bool allow_any_map_path = false;
  // ~load_map, ~reset and ~refine wait this long at most for the keyframe in progress, then answer
  // "busy" and change nothing.
  double service_timeout_s = 10.0;
  // Autosave: the map (as ~save_map writes it) to autosave_path (resolved like ~save_map's paths)
  // every autosave_period_s when it changed, and at shutdown. 0 = off. An empty path is the
  // node's name: "<node>.autosave.json" (ros_params fills it in), so two nodes never share one.
  double autosave_period_s = 60.0;
  std::string autosave_path;
  // A map file loaded at start (resolved like ~load_map's paths), e.g. autosave.json to resume
  // after a crash or a restart. Empty = start empty; a missing file: start empty (first run); an
  // unreadable one is moved aside (<path>.unreadable-<unix time>) and the node starts empty.
  std::string load_map_on_start;

  int processing_queue_size = 2;  // keyframes waiting for the worker; the oldest is dropped
  // The queued keyframes' images (MB); past it the oldest is dropped too, one always kept.
  double processing_queue_max_mb = 256.0;
  int refine_every_n_keyframes = 10;  // 0 = only on ~refine and at shutdown
  std::string priors_file;            // class priors YAML (ros_params fills in the package's)
  bool publish_object_cloud = true;

  // Every core setting; gravity_down_W in here is derived from gravity_source (see mapperConfig()).
  ObjectMapper::Config mapper;

  // The mapper's config with gravity set from gravity_source: param -> gravity_down_W (unit),
  // estimate
  // -> zero (the mapper estimates it), tf -> gravity_down_W until the TF lookup succeeds.
  ObjectMapper::Config mapperConfig() const;
  // The segmenter options with `detector` applied (meaningless for detector "topic").
  SegmenterOptions segmenterOptions() const;
  Status isValid() const;
  std::string print() const;
  // The settings whose printed value differs from `reference`'s, as "key value, key value"
  // (print()'s keys); "" when none does. The start-up line shows these; the whole print() is DEBUG.
  std::string printChanges(const ObjectDetectionRosConfig& reference) const;
};

}  // namespace mvod
