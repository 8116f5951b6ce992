#include "multiview_object_detection/ros/object_detection_ros_config.h"

#include <cmath>
#include <map>
#include <sstream>
#include <string>

#include "multiview_object_detection/pipeline/types/parameter_ranges.h"

namespace mvod {

ObjectMapper::Config ObjectDetectionRosConfig::mapperConfig() const {
  ObjectMapper::Config config = mapper;
  if (gravity_source == "estimate") {
    config.gravity_down_W = Eigen::Vector3d::Zero();
  } else if (gravity_down_W.allFinite() && gravity_down_W.norm() > 1e-9) {
    config.gravity_down_W = gravity_down_W.normalized();
  } else {
    config.gravity_down_W = gravity_down_W;  // isValid() reports it
  }
  return config;
}

SegmenterOptions ObjectDetectionRosConfig::segmenterOptions() const {
  SegmenterOptions options = segmenter;
  options.detector = detector;
  return options.withDetectorDefaults();
}

Status ObjectDetectionRosConfig::isValid() const {
  if (world_frame.empty()) return Status::Error("world_frame must not be empty");
  if (Status s = checkParameterRange("queue_size", queue_size); !s) return s;
  if (Status s = checkParameterRange("input_min_rate_hz", input_min_rate_hz); !s) return s;
  if (Status s = checkParameterRange("input_timeout_s", input_timeout_s); !s) return s;
  if (Status s = checkParameterRange("diagnostic_period", diagnostic_period); !s) return s;
  if (pose_source != "tf" && pose_source != "topic") {
    return Status::Error("pose_source '" + pose_source + "' is unknown (use tf or topic)");
  }
  if (Status s = checkParameterRange("tf_timeout_s", tf_timeout_s); !s) return s;
  if (Status s = checkParameterRange("pose_max_time_diff_s", pose_max_time_diff_s); !s) return s;
  if (gravity_source != "param" && gravity_source != "tf" && gravity_source != "estimate") {
    return Status::Error("gravity_source '" + gravity_source +
                         "' is unknown (use param, tf or estimate)");
  }
  if (gravity_source == "param" &&
      !(gravity_down_W.allFinite() && std::isfinite(gravity_down_W.norm()) &&
        gravity_down_W.norm() > 1e-9)) {
    return Status::Error("gravity_down must be a finite non-zero vector with gravity_source param");
  }
  if (gravity_source == "tf" && gravity_frame.empty()) {
    return Status::Error("gravity_frame must not be empty with gravity_source tf");
  }
  if (Status s = checkParameterRange("autosave_period_s", autosave_period_s); !s) return s;
  Status status = keyframes.isValid();
  if (!status) return status;
  if (detector != "yolo_seg" && detector != "fastestdet" && detector != "maskrcnn" &&
      detector != "topic") {
    return Status::Error("detector '" + detector +
                         "' is unknown (use auto, yolo_seg, fastestdet, maskrcnn or topic)");
  }
  if (detector != "topic") {
    if (!(status = segmenterOptions().isValid())) return status;
  } else if (const float score = segmenterOptions().score_threshold;
             !(score >= 0.f && score <= 1.f)) {
    return Status::Error("score_threshold must be in [0, 1]");
  }
  if (Status s = checkParameterRange("detections_max_age_s", detections_max_age_s); !s) return s;
  if (Status s = checkParameterRange("service_timeout_s", service_timeout_s); !s) return s;
  if (Status s = checkParameterRange("max_detections_per_frame", max_detections_per_frame); !s)
    return s;
  if (Status s = checkParameterRange("processing_queue_size", processing_queue_size); !s) return s;
  if (Status s = checkParameterRange("processing_queue_max_mb", processing_queue_max_mb); !s) {
    return s;
  }
  if (Status s = checkParameterRange("refine_every_n_keyframes", refine_every_n_keyframes); !s)
    return s;
  return mapperConfig().isValid();
}

std::string ObjectDetectionRosConfig::print() const {
  std::ostringstream out;
  out << "world_frame: " << world_frame << "\n"
      << "output_frame: " << outputFrame()
      << (publishesOutputFrame() ? " (gravity-aligned, TF)" : "") << "\n"
      << "camera_frame: " << (camera_frame.empty() ? "(image frame_id)" : camera_frame) << "\n"
      << "depth_registered: " << (depth_registered ? "true" : "false") << "\n"
      << "queue_size: " << queue_size << "\n"
      << "exact_sync: " << (exact_sync ? "true" : "false") << "\n"
      << "input_min_rate_hz: " << input_min_rate_hz << "\n"
      << "input_timeout_s: " << input_timeout_s << "\n"
      << "diagnostic_period: " << diagnostic_period << "\n"
      << "pose_source: " << pose_source << "\n"
      << "tf_timeout_s: " << tf_timeout_s << "\n"
      << "pose_max_time_diff_s: " << pose_max_time_diff_s << "\n"
      << "gravity_source: " << gravity_source << "\n"
      << "gravity_down: [" << gravity_down_W.x() << ", " << gravity_down_W.y() << ", "
      << gravity_down_W.z() << "]\n"
      << "gravity_frame: " << gravity_frame << "\n"
      << "keyframe_mode: "
      << (keyframes.mode == KeyframeSelector::Mode::kExternal
              ? std::string("topic")
              : KeyframeSelector::modeName(keyframes.mode))
      << "\n"
      << "keyframe_every_n: " << keyframes.every_n << "\n"
      << "keyframe_min_translation_m: " << keyframes.min_translation_m << "\n"
      << "keyframe_min_rotation_deg: " << keyframes.min_rotation_deg << "\n"
      << "detector: " << detector << "\n"
      << "model_dir: "
      << (segmenter.model_dir.empty()
              ? "($MVOD_MODEL_DIR, else $ROS_HOME/multiview_object_detection/models)"
              : segmenter.model_dir)
      << "\n"
      << "score_threshold: " << segmenter.score_threshold << "\n"
      << "nms_threshold: " << segmenter.nms_threshold << "\n"
      << "mask_threshold: " << segmenter.mask_threshold << "\n"
      << "detector_backend: " << segmenter.backend << "\n"
      << "detections_max_age_s: " << detections_max_age_s << "\n"
      << "max_detections_per_frame: " << max_detections_per_frame << "\n"
      << "map_directory: " << (map_directory.empty() ? "(~/.ros default)" : map_directory) << "\n"
      << "allow_any_map_path: " << (allow_any_map_path ? "true" : "false") << "\n"
      << "service_timeout_s: " << service_timeout_s << "\n"
      << "processing_queue_size: " << processing_queue_size << "\n"
      << "processing_queue_max_mb: " << processing_queue_max_mb << "\n"
      << "refine_every_n_keyframes: " << refine_every_n_keyframes << "\n"
      << "priors_file: " << priors_file << "\n"
      << "publish_object_cloud: " << (publish_object_cloud ? "true" : "false") << "\n";
  // The mapper's gravity_down_W is gravity_down above (printed once, under the parameter's name).
  std::istringstream mapper(mapperConfig().print());
  for (std::string line; std::getline(mapper, line);) {
    if (line.rfind("gravity_down_W:", 0) != 0) out << line << "\n";
  }
  return out.str();
}

namespace {

// print()'s "key: value" lines as key -> value.
std::map<std::string, std::string> printedSettings(const std::string& text) {
  std::map<std::string, std::string> settings;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    const size_t colon = line.find(": ");
    if (colon != std::string::npos) settings[line.substr(0, colon)] = line.substr(colon + 2);
  }
  return settings;
}

}  // namespace

std::string ObjectDetectionRosConfig::printChanges(
    const ObjectDetectionRosConfig& reference) const {
  const std::map<std::string, std::string> defaults = printedSettings(reference.print());
  std::string changes;
  for (const auto& [key, value] : printedSettings(print())) {
    const auto it = defaults.find(key);
    if (it != defaults.end() && it->second == value) continue;
    if (!changes.empty()) changes += ", ";
    changes += key + " " + value;
  }
  return changes;
}

}  // namespace mvod
