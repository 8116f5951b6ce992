#include "multiview_object_detection/ros/object_detection_ros.h"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <ros/this_node.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <boost/bind/bind.hpp>
#include <cctype>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>
#include <utility>

#include "multiview_object_detection/pipeline/class_priors.h"
#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/ros/ros_params.h"
#include "multiview_object_detection/detectors/segmenter_factory.h"

namespace mvod {
namespace {

using Clock = std::chrono::steady_clock;

constexpr double kLogThrottlePeriodS = 5.0;
constexpr size_t kMaxPendingFrames = 100;
constexpr size_t kMaxBufferedPoses = 2000;
constexpr size_t kMaxBufferedDetections = 300;
constexpr size_t kMaxPathPoses = 100000;
// Detections are matched to a keyframe by the colour image's stamp, which a detector copies.
constexpr double kDetectionStampToleranceS = 1e-3;

double msSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Throttling by message kind rather than by call site: repeats of one problem (differing only in
// stamps and counts) are printed every kLogThrottlePeriodS, while a different problem on the same
// line still shows at once.
bool shouldLog(const std::string& text) {
  static std::mutex mutex;
  static std::map<std::string, Clock::time_point> last_logged;
  std::string key;
  key.reserve(text.size());
  for (const char c : text) {
    if (!std::isdigit(static_cast<unsigned char>(c))) key.push_back(c);
  }
  std::lock_guard<std::mutex> lock(mutex);
  if (last_logged.size() > 1000) last_logged.clear();
  const Clock::time_point now = Clock::now();
  const auto it = last_logged.find(key);
  if (it != last_logged.end() &&
      std::chrono::duration<double>(now - it->second).count() < kLogThrottlePeriodS) {
    return false;
  }
  last_logged[key] = now;
  return true;
}

void errorThrottled(const std::string& text) {
  if (shouldLog(text)) ROS_ERROR("%s", text.c_str());
}

void warnThrottled(const std::string& text) {
  if (shouldLog(text)) ROS_WARN("%s", text.c_str());
}

std::string stampText(const ros::Time& stamp) {
  char text[32];
  std::snprintf(text, sizeof(text), "%u.%09u", stamp.sec, stamp.nsec);
  return text;
}

std::string idList(const std::vector<int>& ids) {
  std::ostringstream out;
  out << "[";
  for (size_t i = 0; i < ids.size(); ++i) out << (i > 0 ? ", " : "") << ids[i];
  out << "]";
  return out.str();
}

multiview_object_detection::ObjectDetectionConfig reconfigureFromConfig(
    const ObjectDetectionRosConfig& config) {
  multiview_object_detection::ObjectDetectionConfig rc;
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
  return rc;
}

void applyReconfigure(const multiview_object_detection::ObjectDetectionConfig& rc,
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
}

diagnostic_msgs::KeyValue keyValue(const std::string& key, double value) {
  diagnostic_msgs::KeyValue kv;
  kv.key = key;
  std::ostringstream out;
  out << value;
  kv.value = out.str();
  return kv;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Construction and shutdown

ObjectDetectionRos::ObjectDetectionRos(const ros::NodeHandle& nh, const ros::NodeHandle& nh_private)
    : nh_(nh), nh_private_(nh_private) {
  std::vector<std::string> errors;
  config_ = getObjectDetectionConfigFromRosParam(nh_private_, &errors);
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
    : nh_(nh), nh_private_(nh_private), config_(config) {
  start(std::move(segmenter));
}

ObjectDetectionRos::~ObjectDetectionRos() { shutdown(); }

void ObjectDetectionRos::fail(const std::string& message) {
  ok_ = false;
  startup_error_ = message;
  ROS_ERROR("object detection does not start: %s", message.c_str());
}

void ObjectDetectionRos::start(std::unique_ptr<InstanceSegmenter> segmenter) {
  const Status valid = config_.isValid();
  if (!valid) {
    fail("invalid parameter in " + nh_private_.getNamespace() + ": " + valid.message());
    return;
  }
  if (config_.priors_file.empty()) {
    fail("priors_file is not set and the package's config/class_priors.yaml was not found");
    return;
  }
  ClassPriors priors;
  const Status loaded = ClassPriors::loadYaml(config_.priors_file, &priors);
  if (!loaded) {
    fail("cannot load the class priors (priors_file): " + loaded.message());
    return;
  }
  if (config_.detector != "topic") {
    if (segmenter) {
      segmenter_ = std::move(segmenter);
      segmenter_injected_ = true;
    } else {
      const Status created = createInstanceSegmenter(config_.segmenterOptions(), &segmenter_);
      if (!created) {
        fail("detector '" + config_.detector + "': " + created.message());
        return;
      }
    }
  }
  mapper_ = std::make_unique<ObjectMapper>(config_.mapperConfig(), priors);
  selector_ = KeyframeSelector(config_.keyframes);
  topics_.depth = config_.depth_registered ? "depth_registered/image_raw" : "depth/image_raw";
  ok_ = true;
  ROS_INFO_STREAM("object detection: " << (segmenter_ ? segmenter_->name() : "detections topic")
                                       << ", priors " << config_.priors_file << "\n"
                                       << config_.print());

  // Outputs (private names) and /diagnostics.
  objects_pub_ = nh_private_.advertise<multiview_object_detection::ObjectArray>("objects", 1, true);
  markers_pub_ = nh_private_.advertise<visualization_msgs::MarkerArray>("markers", 1, true);
  object_cloud_pub_ = nh_private_.advertise<sensor_msgs::PointCloud2>("object_cloud", 1, true);
  keyframes_pub_ = nh_private_.advertise<nav_msgs::Path>("keyframes", 1, true);
  diagnostics_pub_ = nh_.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 10);
  it_ = std::make_unique<image_transport::ImageTransport>(nh_);
  private_it_ = std::make_unique<image_transport::ImageTransport>(nh_private_);
  detections_image_pub_ = private_it_->advertise("detections_image", 1);
  keyframe_path_.header.frame_id = config_.world_frame;

  // Services on their own queue: a long keyframe must not hold up the input callbacks.
  ros::NodeHandle service_nh(nh_private_);
  service_nh.setCallbackQueue(&service_queue_);
  get_objects_srv_ =
      service_nh.advertiseService("get_objects", &ObjectDetectionRos::getObjectsService, this);
  save_map_srv_ =
      service_nh.advertiseService("save_map", &ObjectDetectionRos::saveMapService, this);
  load_map_srv_ =
      service_nh.advertiseService("load_map", &ObjectDetectionRos::loadMapService, this);
  reset_srv_ = service_nh.advertiseService("reset", &ObjectDetectionRos::resetService, this);
  refine_srv_ = service_nh.advertiseService("refine", &ObjectDetectionRos::refineService, this);
  service_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &service_queue_);
  service_spinner_->start();

  // Dynamic reconfigure starts from the values in effect, not from the .cfg defaults.
  reconfigure_server_ = std::make_unique<ReconfigureServer>(reconfigure_mutex_, nh_private_);
  {
    multiview_object_detection::ObjectDetectionConfig rc = reconfigureFromConfig(config_);
    boost::recursive_mutex::scoped_lock lock(reconfigure_mutex_);
    reconfigure_server_->updateConfig(rc);
  }
  reconfigure_server_->setCallback(boost::bind(&ObjectDetectionRos::reconfigureCallback, this,
                                               boost::placeholders::_1, boost::placeholders::_2));

  worker_ = std::thread(&ObjectDetectionRos::workerLoop, this);
  setupInputs();
  diagnostics_timer_ =
      nh_.createWallTimer(ros::WallDuration(1.0), &ObjectDetectionRos::publishDiagnostics, this);
}

void ObjectDetectionRos::setupInputs() {
  tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, nh_);

  // Messages name the inputs as remapped.
  topics_.color = nh_.resolveName(topics_.color);
  topics_.depth = nh_.resolveName(topics_.depth);
  topics_.color_info = nh_.resolveName(topics_.color_info);
  topics_.depth_info = nh_.resolveName(topics_.depth_info);
  const int queue_size = config_.queue_size;
  const image_transport::TransportHints hints("raw", ros::TransportHints(), nh_private_);
  color_sub_.subscribe(*it_, topics_.color, queue_size, hints);
  depth_sub_.subscribe(*it_, topics_.depth, queue_size, hints);
  color_info_sub_.subscribe(nh_, topics_.color_info, queue_size);
  using boost::placeholders::_1;
  using boost::placeholders::_2;
  using boost::placeholders::_3;
  using boost::placeholders::_4;
  if (config_.depth_registered) {
    const auto callback = boost::bind(&ObjectDetectionRos::rgbdCallback, this, _1, _2, _3,
                                      sensor_msgs::CameraInfoConstPtr());
    if (config_.exact_sync) {
      exact_sync3_ = std::make_unique<message_filters::Synchronizer<ExactPolicy3>>(
          ExactPolicy3(queue_size), color_sub_, depth_sub_, color_info_sub_);
      exact_sync3_->registerCallback(callback);
    } else {
      approx_sync3_ = std::make_unique<message_filters::Synchronizer<ApproxPolicy3>>(
          ApproxPolicy3(queue_size), color_sub_, depth_sub_, color_info_sub_);
      approx_sync3_->registerCallback(callback);
    }
  } else {
    depth_info_sub_.subscribe(nh_, topics_.depth_info, queue_size);
    const auto callback = boost::bind(&ObjectDetectionRos::rgbdCallback, this, _1, _2, _3, _4);
    if (config_.exact_sync) {
      exact_sync4_ = std::make_unique<message_filters::Synchronizer<ExactPolicy4>>(
          ExactPolicy4(queue_size), color_sub_, depth_sub_, color_info_sub_, depth_info_sub_);
      exact_sync4_->registerCallback(callback);
    } else {
      approx_sync4_ = std::make_unique<message_filters::Synchronizer<ApproxPolicy4>>(
          ApproxPolicy4(queue_size), color_sub_, depth_sub_, color_info_sub_, depth_info_sub_);
      approx_sync4_->registerCallback(callback);
    }
  }
  if (config_.pose_source == "topic") {
    pose_sub_ = nh_.subscribe("pose", 100, &ObjectDetectionRos::poseCallback, this);
  }
  if (config_.keyframes.mode == KeyframeSelector::Mode::kExternal) {
    keyframe_sub_ = nh_.subscribe("keyframe", 100, &ObjectDetectionRos::keyframeCallback, this);
  }
  if (config_.detector == "topic") {
    detections_sub_ =
        nh_.subscribe("detections", 30, &ObjectDetectionRos::detectionsCallback, this);
  }
  // Frames waiting for a pose are retried when a pose arrives and on this timer (TF, timeouts).
  pending_timer_ = nh_.createWallTimer(ros::WallDuration(0.02), [this](const ros::WallTimerEvent&) {
    std::lock_guard<std::mutex> lock(input_mutex_);
    resolvePendingFrames();
  });
}

void ObjectDetectionRos::shutdown() {
  if (!ok_ || shut_down_.exchange(true)) return;
  // No new input; the queued keyframes are still processed.
  pending_timer_.stop();
  diagnostics_timer_.stop();
  pose_sub_.shutdown();
  keyframe_sub_.shutdown();
  color_sub_.unsubscribe();
  depth_sub_.unsubscribe();
  color_info_sub_.unsubscribe();
  depth_info_sub_.unsubscribe();
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    stop_worker_ = true;
  }
  queue_cv_.notify_all();
  detections_cv_.notify_all();
  if (worker_.joinable()) worker_.join();
  detections_sub_.shutdown();

  // Sec. 3.5 on the final map.
  {
    std::lock_guard<std::mutex> lock(mapper_mutex_);
    refineLocked("shutdown");
  }
  if (ros::ok()) publishMap(ros::Time::now());
  if (service_spinner_) service_spinner_->stop();
  ROS_INFO("object detection stopped: %d keyframes processed, %zu objects in the map",
           statistics().keyframes_processed, objects().size());
}

std::vector<MapObject> ObjectDetectionRos::objects() const {
  std::lock_guard<std::mutex> lock(mapper_mutex_);
  if (!mapper_) return {};
  return databaseObjects(mapper_->database());
}

ObjectDetectionRos::Statistics ObjectDetectionRos::statistics() const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  return stats_;
}

ObjectDetectionRos::Config ObjectDetectionRos::config() const {
  std::lock_guard<std::mutex> lock(config_mutex_);
  return config_;
}

// ---------------------------------------------------------------------------------------------
// Input stage

void ObjectDetectionRos::rgbdCallback(const sensor_msgs::ImageConstPtr& color,
                                      const sensor_msgs::ImageConstPtr& depth,
                                      const sensor_msgs::CameraInfoConstPtr& color_info,
                                      const sensor_msgs::CameraInfoConstPtr& depth_info) {
  if (shut_down_) return;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.frames_received;
  }
  auto reject = [this](const std::string& text) {
    errorThrottled(text);
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.frames_rejected;
  };
  PendingFrame frame;
  frame.msgs.color = color;
  frame.msgs.depth = depth;
  frame.msgs.color_info = color_info;
  frame.msgs.depth_info = depth_info;
  frame.received = Clock::now();
  const Status checked = checkRgbdMessages(frame.msgs, topics_);
  if (!checked) {
    reject("RGB-D input rejected: " + checked.message());
    return;
  }
  {
    std::lock_guard<std::mutex> lock(config_mutex_);
    frame.camera_frame =
        config_.camera_frame.empty() ? color->header.frame_id : config_.camera_frame;
  }
  if (config_.pose_source == "tf" && frame.camera_frame.empty()) {
    reject("RGB-D input rejected: " + describeInput(topics_.color, color->header) +
           " has no frame_id and camera_frame is not set: the camera pose cannot be looked up");
    return;
  }

  std::lock_guard<std::mutex> lock(input_mutex_);
  const ros::Time stamp = color->header.stamp;
  if (!last_input_stamp_.isZero() && stamp <= last_input_stamp_) {
    reject("RGB-D input dropped: " + describeInput(topics_.color, color->header) +
           " is older than or as old as the last frame (stamp " + stampText(last_input_stamp_) +
           "): out-of-order or repeated stamp (call ~reset after restarting a bag)");
    return;
  }
  last_input_stamp_ = stamp;
  pending_.push_back(std::move(frame));
  while (pending_.size() > kMaxPendingFrames) {
    const PendingFrame& oldest = pending_.front();
    errorThrottled("frame " + describeInput(topics_.color, oldest.msgs.color->header) +
                   " dropped: too many frames waiting for their camera pose");
    pending_.pop_front();
    std::lock_guard<std::mutex> stats_lock(stats_mutex_);
    ++stats_.pose_failures;
  }
  resolvePendingFrames();
}

void ObjectDetectionRos::poseCallback(const geometry_msgs::PoseStampedConstPtr& msg) {
  Eigen::Isometry3d T_W_C;
  const Status valid = poseFromMsg(msg->pose, &T_W_C);
  if (!valid) {
    errorThrottled("camera pose " + describeInput(pose_sub_.getTopic(), msg->header) +
                   " ignored: " + valid.message());
    return;
  }
  if (!msg->header.frame_id.empty() && msg->header.frame_id != config_.world_frame) {
    warnThrottled("camera pose " + describeInput(pose_sub_.getTopic(), msg->header) +
                  " is in frame '" + msg->header.frame_id + "', not world_frame '" +
                  config_.world_frame + "': used as if it were world_frame");
  }
  std::lock_guard<std::mutex> lock(input_mutex_);
  const auto it =
      std::upper_bound(poses_.begin(), poses_.end(), msg->header.stamp,
                       [](const ros::Time& stamp, const geometry_msgs::PoseStamped& pose) {
                         return stamp < pose.header.stamp;
                       });
  poses_.insert(it, *msg);
  while (poses_.size() > kMaxBufferedPoses) poses_.pop_front();
  resolvePendingFrames();
}

void ObjectDetectionRos::keyframeCallback(const geometry_msgs::PoseStampedConstPtr& msg) {
  std::lock_guard<std::mutex> lock(input_mutex_);
  selector_.addExternalKeyframe(msg->header.stamp.toSec());
  resolvePendingFrames();
}

void ObjectDetectionRos::detectionsCallback(
    const multiview_object_detection::InstanceDetectionsConstPtr& msg) {
  {
    std::lock_guard<std::mutex> lock(detections_mutex_);
    const auto it = std::upper_bound(
        detections_.begin(), detections_.end(), msg->header.stamp,
        [](const ros::Time& stamp,
           const multiview_object_detection::InstanceDetectionsConstPtr& detections) {
          return stamp < detections->header.stamp;
        });
    detections_.insert(it, msg);
    while (detections_.size() > kMaxBufferedDetections) detections_.pop_front();
  }
  detections_cv_.notify_all();
}

ObjectDetectionRos::Lookup ObjectDetectionRos::lookupCameraPose(const PendingFrame& frame,
                                                                bool timed_out,
                                                                Eigen::Isometry3d* T_W_C,
                                                                Eigen::Isometry3d* T_C_D,
                                                                std::string* error) {
  const std_msgs::Header& header = frame.msgs.color->header;
  const ros::Time stamp = header.stamp;
  std::string world_frame;
  double tf_timeout_s = 0.0;
  double max_diff_s = 0.0;
  std::string pose_source;
  {
    std::lock_guard<std::mutex> lock(config_mutex_);
    world_frame = config_.world_frame;
    tf_timeout_s = config_.tf_timeout_s;
    max_diff_s = config_.pose_max_time_diff_s;
    pose_source = config_.pose_source;
  }
  const std::string what = describeInput(topics_.color, header);

  // Unregistered depth: depth camera -> colour camera, a static transform.
  *T_C_D = Eigen::Isometry3d::Identity();
  if (frame.msgs.depth_info) {
    const std::string& depth_frame = frame.msgs.depth_info->header.frame_id.empty()
                                         ? frame.msgs.depth->header.frame_id
                                         : frame.msgs.depth_info->header.frame_id;
    if (depth_frame.empty() || depth_frame == frame.camera_frame) {
      *T_C_D = Eigen::Isometry3d::Identity();
    } else {
      std::string tf_error;
      if (!tf_buffer_->canTransform(frame.camera_frame, depth_frame, ros::Time(0), &tf_error)) {
        if (!timed_out) return Lookup::kWait;
        *error = "frame " + what + ": no TF '" + frame.camera_frame + "' <- '" + depth_frame +
                 "' (depth to colour camera) after " + std::to_string(tf_timeout_s) +
                 " s: " + tf_error;
        return Lookup::kFailed;
      }
      try {
        const geometry_msgs::TransformStamped tf =
            tf_buffer_->lookupTransform(frame.camera_frame, depth_frame, ros::Time(0));
        const Status valid = transformFromMsg(tf.transform, T_C_D);
        if (!valid) {
          *error = "frame " + what + ": TF '" + frame.camera_frame + "' <- '" + depth_frame +
                   "' is invalid: " + valid.message();
          return Lookup::kFailed;
        }
      } catch (const tf2::TransformException& e) {
        *error = "frame " + what + ": TF lookup failed: " + e.what();
        return Lookup::kFailed;
      }
    }
  }

  if (pose_source == "tf") {
    std::string tf_error;
    if (!tf_buffer_->canTransform(world_frame, frame.camera_frame, stamp, &tf_error)) {
      if (!timed_out) return Lookup::kWait;
      *error = "frame " + what + ": no TF '" + world_frame + "' <- '" + frame.camera_frame +
               "' at the image stamp within tf_timeout_s (" + std::to_string(tf_timeout_s) +
               " s): " + tf_error;
      return Lookup::kFailed;
    }
    try {
      const geometry_msgs::TransformStamped tf =
          tf_buffer_->lookupTransform(world_frame, frame.camera_frame, stamp);
      const Status valid = transformFromMsg(tf.transform, T_W_C);
      if (!valid) {
        *error = "frame " + what + ": TF '" + world_frame + "' <- '" + frame.camera_frame +
                 "' is invalid: " + valid.message();
        return Lookup::kFailed;
      }
    } catch (const tf2::TransformException& e) {
      *error = "frame " + what + ": TF lookup failed: " + e.what();
      return Lookup::kFailed;
    }
    return Lookup::kReady;
  }

  // pose_source topic: the nearest pose in time. Once a pose at or after the image stamp has
  // arrived, later poses can only be further away.
  const geometry_msgs::PoseStamped* best = nullptr;
  double best_dt = std::numeric_limits<double>::infinity();
  for (const geometry_msgs::PoseStamped& pose : poses_) {
    const double dt = std::abs((pose.header.stamp - stamp).toSec());
    if (dt < best_dt) {
      best_dt = dt;
      best = &pose;
    }
  }
  const bool final_answer = timed_out || (!poses_.empty() && poses_.back().header.stamp >= stamp);
  if (!final_answer) return Lookup::kWait;
  if (best == nullptr || best_dt > max_diff_s) {
    std::ostringstream text;
    text << "frame " << what << ": no camera pose on '" << pose_sub_.getTopic()
         << "' within pose_max_time_diff_s (" << max_diff_s << " s) of the image stamp";
    if (best != nullptr) {
      text << " (nearest " << best_dt << " s away)";
    } else {
      text << " (none received yet)";
    }
    *error = text.str();
    return Lookup::kFailed;
  }
  const Status valid = poseFromMsg(best->pose, T_W_C);
  if (!valid) {
    *error = "frame " + what + ": camera pose is invalid: " + valid.message();
    return Lookup::kFailed;
  }
  return Lookup::kReady;
}

void ObjectDetectionRos::resolvePendingFrames() {
  if (shut_down_) return;
  double tf_timeout_s = 0.0;
  {
    std::lock_guard<std::mutex> lock(config_mutex_);
    tf_timeout_s = config_.tf_timeout_s;
  }
  while (!pending_.empty()) {
    const PendingFrame& frame = pending_.front();
    const bool timed_out = secondsSince(frame.received) >= tf_timeout_s;
    Eigen::Isometry3d T_W_C = Eigen::Isometry3d::Identity();
    Eigen::Isometry3d T_C_D = Eigen::Isometry3d::Identity();
    std::string error;
    const Lookup lookup = lookupCameraPose(frame, timed_out, &T_W_C, &T_C_D, &error);
    if (lookup == Lookup::kWait) break;
    if (lookup == Lookup::kFailed) {
      errorThrottled(error);
      pending_.pop_front();
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.pose_failures;
      continue;
    }
    const ros::Time stamp = frame.msgs.color->header.stamp;
    // keyframe_mode topic: wait (up to tf_timeout_s) until the keyframe stream has passed this
    // stamp.
    if (!selector_.canDecide(stamp.toSec()) && !timed_out) break;
    if (selector_.isKeyframe(T_W_C, stamp.toSec())) {
      KeyframeJob job;
      job.msgs = frame.msgs;
      job.camera_frame = frame.camera_frame;
      job.T_W_C = T_W_C;
      job.T_C_D = T_C_D;
      job.received = frame.received;
      job.index = next_keyframe_index_++;

      geometry_msgs::PoseStamped pose;
      pose.header.frame_id = keyframe_path_.header.frame_id;
      pose.header.stamp = stamp;
      pose.pose = poseToMsg(T_W_C);
      keyframe_path_.header.stamp = stamp;
      keyframe_path_.poses.push_back(pose);
      if (keyframe_path_.poses.size() > kMaxPathPoses) {
        keyframe_path_.poses.erase(keyframe_path_.poses.begin());
      }
      keyframes_pub_.publish(keyframe_path_);
      enqueueKeyframe(std::move(job));
    }
    pending_.pop_front();
  }
}

void ObjectDetectionRos::enqueueKeyframe(KeyframeJob job) {
  int dropped_total = 0;
  std::string dropped_what;
  int queue_length = 0;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    int max_size = 1;
    {
      std::lock_guard<std::mutex> config_lock(config_mutex_);
      max_size = config_.processing_queue_size;
    }
    queue_.push_back(std::move(job));
    while (static_cast<int>(queue_.size()) > max_size) {
      dropped_what = describeInput(topics_.color, queue_.front().msgs.color->header);
      queue_.pop_front();
      std::lock_guard<std::mutex> stats_lock(stats_mutex_);
      dropped_total = ++stats_.keyframes_dropped;
    }
    queue_length = static_cast<int>(queue_.size());
  }
  queue_cv_.notify_one();
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.keyframes_selected;
    stats_.queue_length = queue_length;
  }
  if (!dropped_what.empty()) {
    ROS_WARN_THROTTLE(kLogThrottlePeriodS,
                      "processing queue full (processing_queue_size %d): dropped the oldest "
                      "keyframe %s; %d keyframes dropped so far (processing is slower than the "
                      "keyframe rate)",
                      queue_length, dropped_what.c_str(), dropped_total);
  }
}

// ---------------------------------------------------------------------------------------------
// Worker

void ObjectDetectionRos::workerLoop() {
  while (true) {
    KeyframeJob job;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      queue_cv_.wait(lock, [this] { return stop_worker_ || !queue_.empty(); });
      if (queue_.empty()) return;  // stopping and nothing left
      job = std::move(queue_.front());
      queue_.pop_front();
      std::lock_guard<std::mutex> stats_lock(stats_mutex_);
      stats_.queue_length = static_cast<int>(queue_.size());
    }
    try {
      processKeyframe(job);
    } catch (const std::exception& e) {
      // Nothing may take the node down; a bug in a stage costs one keyframe.
      errorThrottled("keyframe " + describeInput(topics_.color, job.msgs.color->header) +
                     ": processing failed with an exception: " + e.what());
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.keyframes_failed;
    }
  }
}

void ObjectDetectionRos::applyPendingReconfigure() {
  Config config;
  bool mapper_dirty = false;
  bool segmenter_dirty = false;
  {
    std::lock_guard<std::mutex> lock(config_mutex_);
    config = config_;
    std::swap(mapper_dirty, mapper_config_dirty_);
    std::swap(segmenter_dirty, segmenter_dirty_);
  }
  if (mapper_dirty) {
    std::lock_guard<std::mutex> lock(mapper_mutex_);
    ObjectMapper::Config mapper_config = config.mapperConfig();
    mapper_config.gravity_down_W = mapper_->config().gravity_down_W;  // not reconfigurable
    const Status updated = mapper_->updateConfig(mapper_config);
    if (!updated) ROS_ERROR("reconfigured mapper settings refused: %s", updated.message().c_str());
  }
  if (segmenter_dirty && config.detector != "topic" && !segmenter_injected_) {
    std::unique_ptr<InstanceSegmenter> segmenter;
    const Status created = createInstanceSegmenter(config.segmenterOptions(), &segmenter);
    if (created) {
      segmenter_ = std::move(segmenter);
      ROS_INFO("detector reloaded with score_threshold %.3f", config.segmenter.score_threshold);
    } else {
      ROS_ERROR("detector reload failed, the previous one is kept: %s", created.message().c_str());
    }
  }
}

bool ObjectDetectionRos::updateGravityFromTf(const std::string& what) {
  std::string world_frame;
  std::string gravity_frame;
  {
    std::lock_guard<std::mutex> lock(config_mutex_);
    world_frame = config_.world_frame;
    gravity_frame = config_.gravity_frame;
  }
  std::string tf_error;
  Eigen::Isometry3d T_W_G;
  Status valid = Status::Error("no transform");
  if (tf_buffer_->canTransform(world_frame, gravity_frame, ros::Time(0), &tf_error)) {
    try {
      valid = transformFromMsg(
          tf_buffer_->lookupTransform(world_frame, gravity_frame, ros::Time(0)).transform, &T_W_G);
      if (!valid) tf_error = valid.message();
    } catch (const tf2::TransformException& e) {
      tf_error = e.what();
    }
  }
  if (!valid) {
    warnThrottled(what + " skipped: waiting for gravity (gravity_source tf): no TF '" +
                  world_frame + "' <- '" + gravity_frame + "': " + tf_error);
    return false;
  }
  // Gravity points along -z of gravity_frame (REP 103: z up).
  const Eigen::Vector3d gravity_down_W = -T_W_G.linear().col(2);
  std::lock_guard<std::mutex> lock(mapper_mutex_);
  ObjectMapper::Config mapper_config = mapper_->config();
  mapper_config.gravity_down_W = gravity_down_W;
  const Status updated = mapper_->updateConfig(mapper_config);
  if (!updated) {
    errorThrottled("gravity from TF refused: " + updated.message());
    return false;
  }
  gravity_from_tf_known_ = true;
  ROS_INFO("gravity from TF '%s' <- '%s': down = [%.3f, %.3f, %.3f] in %s", world_frame.c_str(),
           gravity_frame.c_str(), gravity_down_W.x(), gravity_down_W.y(), gravity_down_W.z(),
           world_frame.c_str());
  return true;
}

bool ObjectDetectionRos::waitForDetections(const KeyframeJob& job, const cv::Size& image_size,
                                           std::vector<Detection2D>* detections) {
  const std_msgs::Header& header = job.msgs.color->header;
  const ros::Time stamp = header.stamp;
  double max_age_s = 0.0;
  {
    std::lock_guard<std::mutex> lock(config_mutex_);
    max_age_s = config_.detections_max_age_s;
  }
  const Clock::time_point deadline = job.received + std::chrono::duration_cast<Clock::duration>(
                                                        std::chrono::duration<double>(max_age_s));
  const std::string what = "keyframe " + describeInput(topics_.color, header);
  multiview_object_detection::InstanceDetectionsConstPtr match;
  {
    std::unique_lock<std::mutex> lock(detections_mutex_);
    while (true) {
      // Keyframes come in stamp order: detections older than this one are not needed any more.
      while (!detections_.empty() &&
             (detections_.front()->header.stamp - stamp).toSec() < -kDetectionStampToleranceS) {
        detections_.pop_front();
      }
      if (!detections_.empty() && std::abs((detections_.front()->header.stamp - stamp).toSec()) <=
                                      kDetectionStampToleranceS) {
        match = detections_.front();
        detections_.pop_front();
        break;
      }
      if (Clock::now() >= deadline || shut_down_) break;
      detections_cv_.wait_until(lock, deadline);
    }
  }
  if (!match) {
    errorThrottled(what + " skipped: no detections with its stamp on '" +
                   detections_sub_.getTopic() + "' within detections_max_age_s (" +
                   std::to_string(max_age_s) + " s)");
    return false;
  }
  std::vector<std::string> warnings;
  const Status converted =
      detectionsFromMsg(*match, image_size, detections_sub_.getTopic(), detections, &warnings);
  for (const std::string& warning : warnings) warnThrottled(warning);
  if (!converted) {
    errorThrottled(what + " skipped: " + converted.message());
    return false;
  }
  return true;
}

void ObjectDetectionRos::processKeyframe(const KeyframeJob& job) {
  const std_msgs::Header& header = job.msgs.color->header;
  const std::string what = "keyframe " + describeInput(topics_.color, header);
  auto failed = [this](const std::string& text) {
    errorThrottled(text);
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.keyframes_failed;
  };
  applyPendingReconfigure();
  const Config config = this->config();

  if (config.gravity_source == "tf" && !gravity_from_tf_known_ && !updateGravityFromTf(what)) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.waiting_for_gravity = true;
    return;
  }

  RgbdFrame frame;
  const Status converted = rgbdFrameFromMsgs(job.msgs, topics_, job.T_W_C, job.T_C_D, &frame);
  if (!converted) {
    failed(what + " skipped: " + converted.message());
    return;
  }
  frame.index = job.index;

  // Sec. 3.1: instances in the colour image.
  std::vector<Detection2D> detections;
  double detection_ms = 0.0;
  if (config.detector == "topic") {
    if (!waitForDetections(job, frame.color_bgr.size(), &detections)) {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.keyframes_failed;
      return;
    }
  } else {
    const Clock::time_point start = Clock::now();
    std::vector<std::string> warnings;
    const Status detected = segmenter_->detect(frame.color_bgr, frame.name, &detections, &warnings);
    detection_ms = msSince(start);
    for (const std::string& warning : warnings) warnThrottled(what + ": " + warning);
    if (!detected) {
      failed(what + " skipped: detector " + segmenter_->name() + ": " + detected.message());
      return;
    }
  }
  // score_threshold may have been raised at run time; external detectors are held to it too.
  detections.erase(std::remove_if(detections.begin(), detections.end(),
                                  [&config](const Detection2D& d) {
                                    return !(d.score >= config.segmenter.score_threshold);
                                  }),
                   detections.end());

  if (detections_image_pub_.getNumSubscribers() > 0) {
    detections_image_pub_.publish(
        colorImageToMsg(drawDetections(frame.color_bgr, detections), header));
  }

  KeyframeReport report;
  Status processed;
  {
    std::lock_guard<std::mutex> lock(mapper_mutex_);
    processed = mapper_->processKeyframe(frame, detections, &report);
    if (processed && config.refine_every_n_keyframes > 0 &&
        mapper_->keyframesProcessed() % config.refine_every_n_keyframes == 0) {
      refineLocked("every " + std::to_string(config.refine_every_n_keyframes) + " keyframes");
    }
  }
  if (!processed) {
    failed(what + " skipped: " + processed.message());
    return;
  }
  for (const std::string& warning : report.warnings) warnThrottled(warning);
  ROS_DEBUG("%s: %d detections, %d above lambda, %d boxes, %d inserted, %d fused, %.1f ms",
            what.c_str(), report.detections, report.above_threshold, report.with_box,
            report.inserted, report.fused, report.times.total_ms);
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.keyframes_processed;
    stats_.waiting_for_gravity = report.waiting_for_gravity;
    stats_.detection_ms = detection_ms;
    stats_.stage_times = report.times;
  }
  publishMap(header.stamp);
}

void ObjectDetectionRos::refineLocked(const std::string& why) {
  if (!mapper_) return;
  const ObjectMapper::RefinementReport report = mapper_->refine();
  removed_atypical_ += static_cast<int>(report.atypical_ids.size());
  removed_intersecting_ += static_cast<int>(report.intersecting_ids.size());
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.removed_atypical = removed_atypical_;
    stats_.removed_intersecting = removed_intersecting_;
    stats_.stage_times.refinement_ms = report.time_ms;
  }
  if (!report.atypical_ids.empty() || !report.intersecting_ids.empty()) {
    ROS_INFO("refinement (%s): removed atypical %s, intersecting %s (%.1f ms)", why.c_str(),
             idList(report.atypical_ids).c_str(), idList(report.intersecting_ids).c_str(),
             report.time_ms);
  }
}

// ---------------------------------------------------------------------------------------------
// Output

void ObjectDetectionRos::publishMap(const ros::Time& stamp) {
  const std::vector<MapObject> objects = this->objects();
  std_msgs::Header header;
  header.frame_id = config_.world_frame;
  header.stamp = stamp;
  {
    // One lock for objects and markers: the DELETEs must follow the published id set in order.
    std::lock_guard<std::mutex> lock(publish_mutex_);
    objects_pub_.publish(objectsToMsg(objects, header));
    markers_pub_.publish(objectsToMarkers(objects, header, &published_marker_ids_));
    if (config_.publish_object_cloud) {
      sensor_msgs::PointCloud2 cloud;
      objectsToPointCloud2(objects, header, &cloud);
      object_cloud_pub_.publish(cloud);
    }
  }
  std::lock_guard<std::mutex> lock(stats_mutex_);
  stats_.objects = static_cast<int>(objects.size());
}

void ObjectDetectionRos::publishDiagnostics(const ros::WallTimerEvent& /*event*/) {
  const Statistics stats = statistics();
  diagnostic_msgs::DiagnosticStatus status;
  status.name = "object_detection: " + ros::this_node::getName();
  status.hardware_id = config_.world_frame;
  status.level = diagnostic_msgs::DiagnosticStatus::OK;
  status.message = "ok";
  if (stats.keyframes_dropped > dropped_at_last_diagnostics_) {
    status.level = diagnostic_msgs::DiagnosticStatus::WARN;
    status.message = "keyframes dropped: processing is slower than the keyframe rate";
  } else if (stats.waiting_for_gravity) {
    status.level = diagnostic_msgs::DiagnosticStatus::WARN;
    status.message = "waiting for gravity";
  }
  dropped_at_last_diagnostics_ = stats.keyframes_dropped;
  status.values = {
      keyValue("frames received", stats.frames_received),
      keyValue("frames rejected", stats.frames_rejected),
      keyValue("pose failures", stats.pose_failures),
      keyValue("keyframes selected", stats.keyframes_selected),
      keyValue("keyframes dropped", stats.keyframes_dropped),
      keyValue("keyframes processed", stats.keyframes_processed),
      keyValue("keyframes failed", stats.keyframes_failed),
      keyValue("queue length", stats.queue_length),
      keyValue("objects", stats.objects),
      keyValue("removed atypical", stats.removed_atypical),
      keyValue("removed intersecting", stats.removed_intersecting),
      keyValue("detection ms", stats.detection_ms),
      keyValue("extraction ms", stats.stage_times.extraction_ms),
      keyValue("filter ms", stats.stage_times.filter_ms),
      keyValue("lccp ms", stats.stage_times.lccp_ms),
      keyValue("manhattan ms", stats.stage_times.manhattan_ms),
      keyValue("fusion ms", stats.stage_times.fusion_ms),
      keyValue("refinement ms", stats.stage_times.refinement_ms),
      keyValue("keyframe total ms", stats.stage_times.total_ms),
  };
  diagnostic_msgs::DiagnosticArray array;
  array.header.stamp = ros::Time::now();
  array.status.push_back(status);
  diagnostics_pub_.publish(array);
}

// ---------------------------------------------------------------------------------------------
// Services

bool ObjectDetectionRos::getObjectsService(
    multiview_object_detection::GetObjects::Request& request,
    multiview_object_detection::GetObjects::Response& response) {
  const std::set<int> ids(request.ids.begin(), request.ids.end());
  std::vector<MapObject> selected;
  for (MapObject& object : objects()) {
    if (!request.class_name.empty() && object.class_name != request.class_name) continue;
    if (!ids.empty() && ids.count(object.id) == 0) continue;
    selected.push_back(std::move(object));
  }
  std_msgs::Header header;
  header.frame_id = config_.world_frame;
  header.stamp = ros::Time::now();
  response.objects = objectsToMsg(selected, header);
  return true;
}

bool ObjectDetectionRos::saveMapService(multiview_object_detection::MapFile::Request& request,
                                        multiview_object_detection::MapFile::Response& response) {
  if (request.path.empty()) {
    response.success = false;
    response.message = "save_map: the path is empty";
    return true;
  }
  std::vector<MapObject> objects;
  MapSummary summary;
  {
    std::lock_guard<std::mutex> lock(mapper_mutex_);
    objects = databaseObjects(mapper_->database());
    summary.keyframes = mapper_->keyframesProcessed();
    summary.gravity_down_W = -mapper_->gravity().up;
    summary.removed_atypical = removed_atypical_;
    summary.removed_intersecting = removed_intersecting_;
  }
  summary.frames = statistics().frames_received;
  const Status written = writeFileAtomic(request.path, objectsToJson(objects, summary, true));
  response.success = written.ok();
  response.message = written
                         ? "saved " + std::to_string(objects.size()) + " objects to " + request.path
                         : "save_map: " + written.message();
  if (written) {
    ROS_INFO("%s", response.message.c_str());
  } else {
    ROS_ERROR("%s", response.message.c_str());
  }
  return true;
}

bool ObjectDetectionRos::loadMapService(multiview_object_detection::MapFile::Request& request,
                                        multiview_object_detection::MapFile::Response& response) {
  std::string text;
  std::vector<MapObject> loaded;
  MapSummary summary;
  Status status = readFile(request.path, &text);
  if (status) status = objectsFromJson(text, &loaded, &summary);
  if (!status) {
    response.success = false;
    response.message = "load_map refused '" + request.path + "': " + status.message() +
                       "; the current map (" + std::to_string(objects().size()) +
                       " objects) is kept";
    ROS_ERROR("%s", response.message.c_str());
    return true;
  }
  {
    std::lock_guard<std::mutex> lock(mapper_mutex_);
    mapper_->mutableDatabase().setObjects(loaded);
    removed_atypical_ = summary.removed_atypical;
    removed_intersecting_ = summary.removed_intersecting;
  }
  response.success = true;
  response.message = "loaded " + std::to_string(loaded.size()) + " objects from " + request.path;
  ROS_INFO("%s", response.message.c_str());
  publishMap(ros::Time::now());
  return true;
}

bool ObjectDetectionRos::resetService(std_srvs::Trigger::Request& /*request*/,
                                      std_srvs::Trigger::Response& response) {
  size_t removed = 0;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    queue_.clear();
  }
  {
    std::lock_guard<std::mutex> lock(mapper_mutex_);
    removed = mapper_->database().size();
    mapper_->reset();
    removed_atypical_ = 0;
    removed_intersecting_ = 0;
  }
  {
    std::lock_guard<std::mutex> lock(input_mutex_);
    pending_.clear();
    selector_.reset();
    last_input_stamp_ = ros::Time();  // a restarted bag may begin again
    keyframe_path_.poses.clear();
    keyframe_path_.header.stamp = ros::Time::now();
    keyframes_pub_.publish(keyframe_path_);
  }
  publishMap(ros::Time::now());
  response.success = true;
  response.message =
      "map reset: " + std::to_string(removed) + " objects removed (ids keep counting)";
  ROS_INFO("%s", response.message.c_str());
  return true;
}

bool ObjectDetectionRos::refineService(std_srvs::Trigger::Request& /*request*/,
                                       std_srvs::Trigger::Response& response) {
  ObjectMapper::RefinementReport report;
  {
    std::lock_guard<std::mutex> lock(mapper_mutex_);
    const int atypical_before = removed_atypical_;
    const int intersecting_before = removed_intersecting_;
    refineLocked("~refine");
    response.message =
        "refinement removed " + std::to_string(removed_atypical_ - atypical_before) +
        " atypical and " + std::to_string(removed_intersecting_ - intersecting_before) +
        " intersecting objects; " + std::to_string(mapper_->database().size()) + " objects left";
  }
  response.success = true;
  publishMap(ros::Time::now());
  return true;
}

void ObjectDetectionRos::reconfigureCallback(multiview_object_detection::ObjectDetectionConfig& rc,
                                             uint32_t /*level*/) {
  KeyframeSelector::Config keyframes;
  {
    std::lock_guard<std::mutex> lock(config_mutex_);
    Config updated = config_;
    applyReconfigure(rc, &updated);
    const Status valid = updated.isValid();
    if (!valid) {
      ROS_ERROR("dynamic reconfigure refused: %s; the previous values are kept",
                valid.message().c_str());
      rc = reconfigureFromConfig(config_);
      return;
    }
    // Only the reconfigurable (numeric) fields change: the input stage reads the others without
    // the lock.
    const bool score_changed =
        updated.segmenter.score_threshold != config_.segmenter.score_threshold;
    applyReconfigure(rc, &config_);
    mapper_config_dirty_ = true;
    segmenter_dirty_ = segmenter_dirty_ || score_changed;
    keyframes = config_.keyframes;
  }
  // Not nested in config_mutex_: the input stage takes input_mutex_ first.
  std::lock_guard<std::mutex> input_lock(input_mutex_);
  selector_.setConfig(keyframes);
}

}  // namespace mvod
