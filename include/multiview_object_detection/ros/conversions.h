// Every conversion between ROS messages and the core's types, in one place (as
// voxblox_ros/conversions.h and grid_map's GridMapRosConverter). Pure functions: no node handle, no
// logging; errors come back as a Status whose message names the topic, frame and stamp, so the node
// only has to print it.
#pragma once

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Transform.h>
#include <geometry_msgs/Vector3.h>
#include <multiview_object_detection/InstanceDetections.h>
#include <multiview_object_detection/Object.h>
#include <multiview_object_detection/ObjectArray.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/map/object_database.h"
#include "multiview_object_detection/pipeline/types/common.h"
#include "multiview_object_detection/pipeline/types/detection.h"
#include "multiview_object_detection/pipeline/types/rgbd_frame.h"

namespace mvod {

// "'rgb/image_raw' (frame camera_rgb_optical_frame, stamp 12.345678)": how every message names an
// input.
std::string describeInput(const std::string& topic, const std_msgs::Header& header);

// ---- Images and camera info -------------------------------------------------------------------
// bgr8 or rgb8 -> CV_8UC3 BGR (a deep copy). Any other encoding is an error naming it.
Status colorImageFromMsg(const sensor_msgs::Image& msg, const std::string& topic, cv::Mat* bgr);
// 16UC1 / mono16 (millimetres) or 32FC1 (metres) -> CV_16UC1 / CV_32FC1 (a deep copy).
Status depthImageFromMsg(const sensor_msgs::Image& msg, const std::string& topic, cv::Mat* depth);
// K -> fx, fy, cx, cy (+ width, height). An all-zero or non-finite K (an uncalibrated camera) is an
// error.
Status intrinsicsFromCameraInfo(const sensor_msgs::CameraInfo& msg, const std::string& topic,
                                CameraIntrinsics* intrinsics);

// The pieces of one synchronised RGB-D input. depth_info is null for registered depth (the colour
// camera_info then describes both images).
struct RgbdMessages {
  sensor_msgs::ImageConstPtr color;
  sensor_msgs::ImageConstPtr depth;
  sensor_msgs::CameraInfoConstPtr color_info;
  sensor_msgs::CameraInfoConstPtr depth_info;
};
struct RgbdTopics {
  // depth_image_proc's names: the node reads only K, so the images must be rectified.
  std::string color = "rgb/image_rect_color";
  std::string depth = "depth_registered/image_rect";
  std::string color_info = "rgb/camera_info";
  std::string depth_info = "depth/camera_info";
};
// A warning naming the topic when camera_info has non-zero distortion coefficients (the node uses K
// only, so unrectified images would misplace points); empty when D is empty or all zero.
std::string distortionWarning(const sensor_msgs::CameraInfo& msg, const std::string& topic);
// Cheap checks on headers only (encodings, sizes, camera_info), before any pixel is copied.
Status checkRgbdMessages(const RgbdMessages& msgs, const RgbdTopics& topics);
// Images and intrinsics into an RgbdFrame (stamp = colour stamp). T_W_C: colour camera -> world;
// T_C_D: depth camera -> colour camera (identity for registered depth). The frame is validated.
Status rgbdFrameFromMsgs(const RgbdMessages& msgs, const RgbdTopics& topics,
                         const Eigen::Isometry3d& T_W_C, const Eigen::Isometry3d& T_C_D,
                         RgbdFrame* frame);
// BGR image -> bgr8 message.
sensor_msgs::ImagePtr colorImageToMsg(const cv::Mat& bgr, const std_msgs::Header& header);

// ---- Poses ------------------------------------------------------------------------------------
// Rejects NaN/inf and quaternions whose norm is not 1 (within 1e-3: float rounding only); the
// quaternion is normalised.
Status poseFromMsg(const geometry_msgs::Pose& msg, Eigen::Isometry3d* T);
Status transformFromMsg(const geometry_msgs::Transform& msg, Eigen::Isometry3d* T);
geometry_msgs::Pose poseToMsg(const Eigen::Isometry3d& T);
// A box's centre and orientation (its axes).
geometry_msgs::Pose boxPoseToMsg(const OrientedBox& box);
// A box's full extents along its axes (m), as Object.size, BoundingBox3D.size and
// BoundingBox.dimensions hold them.
geometry_msgs::Vector3 boxSizeToMsg(const OrientedBox& box);
geometry_msgs::Transform transformToMsg(const Eigen::Isometry3d& T);

// ---- Detections -------------------------------------------------------------------------------
// InstanceDetections -> Detection2D for an image of image_size. Array length mismatches are an
// error (nothing is returned); per-detection problems (a mask of the wrong size or encoding, a box
// outside the image) drop that detection and are described in `warnings`. class_id -1 or outside
// COCO-80 takes the class from class_names. A score outside [0, 1] drops its detection; of more
// than `max_detections`, the highest-scoring are kept (message order) and `capped` says how many
// were dropped. Masks come back box-sized (see Detection2D).
Status detectionsFromMsg(const multiview_object_detection::InstanceDetections& msg,
                         const cv::Size& image_size, const std::string& topic,
                         std::vector<Detection2D>* detections,
                         std::vector<std::string>* warnings = nullptr, size_t max_detections = 100,
                         size_t* capped = nullptr);
// The reverse (tests, and a detector node of this package's format): masks of the image's size;
// include_masks false leaves `masks` empty (boxes are the masks).
multiview_object_detection::InstanceDetections detectionsToMsg(
    const std::vector<Detection2D>& detections, const cv::Size& image_size,
    const std_msgs::Header& header, bool include_masks = true);

// ---- Objects ----------------------------------------------------------------------------------
multiview_object_detection::Object objectToMsg(const MapObject& object);
// Box, class, probability, counts and stamps back (clouds are not in the message). Rejects a NaN
// pose or a negative size.
Status objectFromMsg(const multiview_object_detection::Object& msg, MapObject* object);
multiview_object_detection::ObjectArray objectsToMsg(const std::vector<MapObject>& objects,
                                                     const std_msgs::Header& header);

}  // namespace mvod
