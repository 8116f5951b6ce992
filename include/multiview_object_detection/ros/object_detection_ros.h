// object_detection_node / ObjectDetectionNodelet: RGB-D frames and camera poses in; objects,
// markers, clouds and services out. A thin layer over mvod::ObjectMapper (voxblox_ros's TsdfServer
// pattern):
//
//   callbacks (never block) -> pose (TF or topic, waited for without blocking) -> keyframe
//   selection
//   -> bounded queue (oldest dropped) -> ONE worker thread: detector + ObjectMapper -> publishers.
//
// Services run on their own callback queue and thread, so a slow keyframe does not stall the input.
#pragma once

#include <dynamic_reconfigure/server.h>
#include <geometry_msgs/PoseStamped.h>
#include <image_transport/image_transport.h>
#include <image_transport/subscriber_filter.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/sync_policies/exact_time.h>
#include <message_filters/synchronizer.h>
#include <multiview_object_detection/GetObjects.h>
#include <multiview_object_detection/InstanceDetections.h>
#include <multiview_object_detection/MapFile.h>
#include <multiview_object_detection/ObjectDetectionConfig.h>
#include <nav_msgs/Path.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "multiview_object_detection/pipeline/keyframe_selector.h"
#include "multiview_object_detection/pipeline/object_mapper.h"
#include "multiview_object_detection/ros/conversions.h"
#include "multiview_object_detection/ros/object_detection_ros_config.h"

namespace mvod {

class ObjectDetectionRos {
 public:
  using Config = ObjectDetectionRosConfig;

  // Counters reported on /diagnostics (and read by tests).
  struct Statistics {
    int frames_received = 0;
    int frames_rejected = 0;  // bad encoding, size, camera_info, out-of-order stamp
    int pose_failures = 0;    // no TF / pose in time, or an invalid pose
    int keyframes_selected = 0;
    int keyframes_dropped = 0;    // the processing queue was full
    int keyframes_processed = 0;  // went through ObjectMapper::processKeyframe
    int keyframes_failed = 0;     // conversion, detector or mapper error; no detections in time
    int queue_length = 0;
    int objects = 0;
    int removed_atypical = 0;
    int removed_intersecting = 0;
    bool waiting_for_gravity = false;
    double detection_ms = 0.0;  // last keyframe
    StageTimes stage_times;     // last keyframe
  };

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

  // Finishes the queued keyframes, refines the map (Sec. 3.5), publishes it once more while ROS is
  // up, and stops the worker. Idempotent; the destructor calls it.
  void shutdown();

  std::vector<MapObject> objects() const;
  Statistics statistics() const;
  Config config() const;

 private:
  using Image = sensor_msgs::Image;
  using CameraInfo = sensor_msgs::CameraInfo;
  using ApproxPolicy3 = message_filters::sync_policies::ApproximateTime<Image, Image, CameraInfo>;
  using ExactPolicy3 = message_filters::sync_policies::ExactTime<Image, Image, CameraInfo>;
  using ApproxPolicy4 =
      message_filters::sync_policies::ApproximateTime<Image, Image, CameraInfo, CameraInfo>;
  using ExactPolicy4 =
      message_filters::sync_policies::ExactTime<Image, Image, CameraInfo, CameraInfo>;
  using ReconfigureServer =
      dynamic_reconfigure::Server<multiview_object_detection::ObjectDetectionConfig>;

  // A synchronised input waiting for its pose (and, in keyframe_mode topic, its keyframe message).
  struct PendingFrame {
    RgbdMessages msgs;
    std::string camera_frame;
    std::chrono::steady_clock::time_point received;
  };
  // A keyframe waiting for the worker.
  struct KeyframeJob {
    RgbdMessages msgs;
    std::string camera_frame;
    Eigen::Isometry3d T_W_C = Eigen::Isometry3d::Identity();
    Eigen::Isometry3d T_C_D = Eigen::Isometry3d::Identity();
    std::chrono::steady_clock::time_point received;
    int index = 0;
  };
  enum class Lookup { kReady, kWait, kFailed };

  void start(std::unique_ptr<InstanceSegmenter> segmenter);
  void fail(const std::string& message);
  void setupInputs();

  // Input stage (ROS callback threads).
  void rgbdCallback(const sensor_msgs::ImageConstPtr& color,
                    const sensor_msgs::ImageConstPtr& depth,
                    const sensor_msgs::CameraInfoConstPtr& color_info,
                    const sensor_msgs::CameraInfoConstPtr& depth_info);
  void poseCallback(const geometry_msgs::PoseStampedConstPtr& msg);
  void keyframeCallback(const geometry_msgs::PoseStampedConstPtr& msg);
  void detectionsCallback(const multiview_object_detection::InstanceDetectionsConstPtr& msg);
  void resolvePendingFrames();  // needs input_mutex_
  Lookup lookupCameraPose(const PendingFrame& frame, bool timed_out, Eigen::Isometry3d* T_W_C,
                          Eigen::Isometry3d* T_C_D, std::string* error);
  void enqueueKeyframe(KeyframeJob job);

  // Worker.
  void workerLoop();
  void processKeyframe(const KeyframeJob& job);
  void applyPendingReconfigure();
  bool updateGravityFromTf(const std::string& what);
  bool waitForDetections(const KeyframeJob& job, const cv::Size& image_size,
                         std::vector<Detection2D>* detections);
  void refineLocked(const std::string& why);  // needs mapper_mutex_

  // Output.
  void publishMap(const ros::Time& stamp);
  void publishDiagnostics(const ros::WallTimerEvent& event);

  // Services and dynamic reconfigure.
  bool getObjectsService(multiview_object_detection::GetObjects::Request& request,
                         multiview_object_detection::GetObjects::Response& response);
  bool saveMapService(multiview_object_detection::MapFile::Request& request,
                      multiview_object_detection::MapFile::Response& response);
  bool loadMapService(multiview_object_detection::MapFile::Request& request,
                      multiview_object_detection::MapFile::Response& response);
  bool resetService(std_srvs::Trigger::Request& request, std_srvs::Trigger::Response& response);
  bool refineService(std_srvs::Trigger::Request& request, std_srvs::Trigger::Response& response);
  void reconfigureCallback(multiview_object_detection::ObjectDetectionConfig& rc, uint32_t level);

  ros::NodeHandle nh_;
  ros::NodeHandle nh_private_;
  bool ok_ = false;
  std::string startup_error_;
  std::atomic<bool> shut_down_{false};

  // Settings: config_ is what is in effect for the input stage; the worker applies reconfigured
  // mapper and detector settings between keyframes. Dynamic reconfigure changes only numeric
  // fields (under config_mutex_); the string and structural fields never change after start.
  mutable std::mutex config_mutex_;
  Config config_;
  bool mapper_config_dirty_ = false;
  bool segmenter_dirty_ = false;
  RgbdTopics topics_;

  // Inputs.
  std::unique_ptr<image_transport::ImageTransport> it_;
  image_transport::SubscriberFilter color_sub_;
  image_transport::SubscriberFilter depth_sub_;
  message_filters::Subscriber<CameraInfo> color_info_sub_;
  message_filters::Subscriber<CameraInfo> depth_info_sub_;
  std::unique_ptr<message_filters::Synchronizer<ApproxPolicy3>> approx_sync3_;
  std::unique_ptr<message_filters::Synchronizer<ExactPolicy3>> exact_sync3_;
  std::unique_ptr<message_filters::Synchronizer<ApproxPolicy4>> approx_sync4_;
  std::unique_ptr<message_filters::Synchronizer<ExactPolicy4>> exact_sync4_;
  ros::Subscriber pose_sub_;
  ros::Subscriber keyframe_sub_;
  ros::Subscriber detections_sub_;
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  ros::WallTimer pending_timer_;

  // Input state (input_mutex_).
  std::mutex input_mutex_;
  std::deque<PendingFrame> pending_;
  std::deque<geometry_msgs::PoseStamped> poses_;  // pose_source topic, sorted by stamp
  ros::Time last_input_stamp_;
  KeyframeSelector selector_;
  int next_keyframe_index_ = 0;
  nav_msgs::Path keyframe_path_;

  // Detections from the topic (detections_mutex_).
  std::mutex detections_mutex_;
  std::condition_variable detections_cv_;
  std::deque<multiview_object_detection::InstanceDetectionsConstPtr> detections_;

  // Worker queue (queue_mutex_).
  std::mutex queue_mutex_;
  std::condition_variable queue_cv_;
  std::deque<KeyframeJob> queue_;
  bool stop_worker_ = false;
  std::thread worker_;

  // The map (mapper_mutex_): the worker and the services.
  mutable std::mutex mapper_mutex_;
  std::unique_ptr<ObjectMapper> mapper_;
  std::unique_ptr<InstanceSegmenter> segmenter_;  // worker only
  bool segmenter_injected_ = false;               // given by the caller: never reloaded
  bool gravity_from_tf_known_ = false;
  int removed_atypical_ = 0;
  int removed_intersecting_ = 0;

  // Outputs.
  ros::Publisher objects_pub_;
  ros::Publisher markers_pub_;
  ros::Publisher object_cloud_pub_;
  ros::Publisher keyframes_pub_;
  ros::Publisher diagnostics_pub_;
  std::unique_ptr<image_transport::ImageTransport> private_it_;
  image_transport::Publisher detections_image_pub_;
  std::mutex publish_mutex_;
  std::set<int> published_marker_ids_;
  ros::WallTimer diagnostics_timer_;

  mutable std::mutex stats_mutex_;
  Statistics stats_;
  int dropped_at_last_diagnostics_ = 0;

  // Services on their own queue and thread.
  ros::CallbackQueue service_queue_;
  std::unique_ptr<ros::AsyncSpinner> service_spinner_;
  ros::ServiceServer get_objects_srv_;
  ros::ServiceServer save_map_srv_;
  ros::ServiceServer load_map_srv_;
  ros::ServiceServer reset_srv_;
  ros::ServiceServer refine_srv_;

  boost::recursive_mutex reconfigure_mutex_;
  std::unique_ptr<ReconfigureServer> reconfigure_server_;
};

}  // namespace mvod
