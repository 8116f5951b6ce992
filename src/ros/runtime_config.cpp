#include "multiview_object_detection/ros/runtime_config.h"

#include <ros/console.h>

#include <utility>

namespace mvod {
namespace {

RuntimeConfig::ReconfigureValues reconfigureFromConfig(const ObjectDetectionRosConfig& config) {
  RuntimeConfig::ReconfigureValues rc;
  rc.keyframe_every_n = config.keyframes.every_n;
  rc.keyframe_min_translation_m = config.keyframes.min_translation_m;
  rc.keyframe_min_rotation_deg = config.keyframes.min_rotation_deg;
  rc.score_threshold = config.segmenter.score_threshold;
  rc.min_probability = config.mapper.min_probability;
  rc.min_object_points = config.mapper.min_object_points;
  rc.database_fusion_voxel_size_m = config.mapper.database.fusion_voxel_size_m;
  rc.database_disable_fusion = config.mapper.database.disable_fusion;
  rc.refine_every_n_keyframes = config.refine_every_n_keyframes;
  rc.prior_filter_enable = config.mapper.prior_filter.enable;
  rc.prior_filter_volume_min_ratio = config.mapper.prior_filter.volume_min_ratio;
  rc.prior_filter_volume_max_ratio = config.mapper.prior_filter.volume_max_ratio;
  rc.prior_filter_edge_min_ratio = config.mapper.prior_filter.edge_min_ratio;
  rc.intersection_filter_enable = config.mapper.intersection_filter.enable;
  rc.intersection_filter_volume_ratio_threshold =
      config.mapper.intersection_filter.volume_ratio_threshold;
  rc.database_existence_enable = config.mapper.database.existence.enable;
  rc.database_existence_remove_below = config.mapper.database.existence.remove_below;
  return rc;
}

void applyReconfigure(const RuntimeConfig::ReconfigureValues& rc,
                      ObjectDetectionRosConfig* config) {
  config->keyframes.every_n = rc.keyframe_every_n;
  config->keyframes.min_translation_m = rc.keyframe_min_translation_m;
  config->keyframes.min_rotation_deg = rc.keyframe_min_rotation_deg;
  config->segmenter.score_threshold = static_cast<float>(rc.score_threshold);
  config->mapper.min_probability = rc.min_probability;
  config->mapper.min_object_points = rc.min_object_points;
  config->mapper.database.fusion_voxel_size_m = rc.database_fusion_voxel_size_m;
  config->mapper.database.disable_fusion = rc.database_disable_fusion;
  config->refine_every_n_keyframes = rc.refine_every_n_keyframes;
  config->mapper.prior_filter.enable = rc.prior_filter_enable;
  config->mapper.prior_filter.volume_min_ratio = rc.prior_filter_volume_min_ratio;
  config->mapper.prior_filter.volume_max_ratio = rc.prior_filter_volume_max_ratio;
  config->mapper.prior_filter.edge_min_ratio = rc.prior_filter_edge_min_ratio;
  config->mapper.intersection_filter.enable = rc.intersection_filter_enable;
  config->mapper.intersection_filter.volume_ratio_threshold =
      rc.intersection_filter_volume_ratio_threshold;
  config->mapper.database.existence.enable = rc.database_existence_enable;
  config->mapper.database.existence.remove_below = rc.database_existence_remove_below;
}

}  // namespace

RuntimeConfig::Config RuntimeConfig::get() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return config_;
}

RuntimeConfig::ReconfigureValues RuntimeConfig::reconfigureValues() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return reconfigureFromConfig(config_);
}

bool RuntimeConfig::reconfigure(ReconfigureValues* values, KeyframeSelector::Config* keyframes) {
  std::lock_guard<std::mutex> lock(mutex_);
  Config updated = config_;
  applyReconfigure(*values, &updated);
  const Status valid = updated.isValid();
  if (!valid) {
    ROS_ERROR("dynamic reconfigure refused: %s; the previous values are kept",
              valid.message().c_str());
    *values = reconfigureFromConfig(config_);
    return false;
  }
  // Only the reconfigurable (numeric) fields change: the stages keep copies of the others.
  const bool score_changed = updated.segmenter.score_threshold != config_.segmenter.score_threshold;
  applyReconfigure(*values, &config_);
  mapper_changed_ = true;
  segmenter_changed_ = segmenter_changed_ || score_changed;
  *keyframes = config_.keyframes;
  return true;
}

RuntimeConfig::Config RuntimeConfig::takeChanges(bool* mapper_changed, bool* segmenter_changed) {
  std::lock_guard<std::mutex> lock(mutex_);
  *mapper_changed = false;
  *segmenter_changed = false;
  std::swap(*mapper_changed, mapper_changed_);
  std::swap(*segmenter_changed, segmenter_changed_);
  return config_;
}

}  // namespace mvod
