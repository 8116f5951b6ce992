// The node's settings while it runs. Dynamic reconfigure changes only the numeric thresholds
// (cfg/ObjectDetection.cfg); the string and structural fields never change after start, so a stage
// may keep its own copy of those and ask here only for the thresholds.
#pragma once

#include <multiview_object_detection/ObjectDetectionConfig.h>

#include <mutex>

#include "multiview_object_detection/pipeline/stages/keyframe_selector.h"
#include "multiview_object_detection/ros/object_detection_ros_config.h"

namespace mvod {

class RuntimeConfig {
 public:
  using Config = ObjectDetectionRosConfig;
  using ReconfigureValues = multiview_object_detection::ObjectDetectionConfig;

  explicit RuntimeConfig(const Config& config) : config_(config) {}

  RuntimeConfig(const RuntimeConfig&) = delete;
  RuntimeConfig& operator=(const RuntimeConfig&) = delete;

  Config get() const;

  // The values in effect, for the dynamic reconfigure server to start from (not the .cfg
  // defaults).
  ReconfigureValues reconfigureValues() const;
  // Applies a dynamic reconfigure request. An invalid result is refused (logged, *values reset to
  // the values in effect) and false returned; otherwise *keyframes is the keyframe selection now in
  // effect. The mapper and detector settings are applied by the worker between keyframes
  // (takeChanges).
  bool reconfigure(ReconfigureValues* values, KeyframeSelector::Config* keyframes);

  // The worker, before each keyframe: the settings in effect and whether the mapper's settings or
  // the detector's score threshold changed since the last call.
  Config takeChanges(bool* mapper_changed, bool* segmenter_changed);

 private:
  mutable std::mutex mutex_;
  Config config_;
  bool mapper_changed_ = false;
  bool segmenter_changed_ = false;
};

}  // namespace mvod
