#include "multiview_object_detection/ros/conversions.h"

#include <cv_bridge/cv_bridge.h>
#include <image_geometry/pinhole_camera_model.h>
#include <sensor_msgs/image_encodings.h>
#include <tf2_eigen/tf2_eigen.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "multiview_object_detection/pipeline/types/class_priors.h"
#include "multiview_object_detection/pipeline/types/intrinsics_check.h"
#include "multiview_object_detection/pipeline/types/oriented_box.h"
#include "multiview_object_detection/ros/input_guard.h"

namespace mvod {
namespace {

namespace enc = sensor_msgs::image_encodings;

constexpr double kQuaternionNormTolerance = 1e-3;

std::string sizeText(uint32_t width, uint32_t height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

// ros::Time throws outside [0, 2^32) s; a bad value becomes 0 (unknown).
ros::Time timeFromSeconds(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0.0 || seconds >= 4294967295.0) return ros::Time(0);
  return ros::Time(seconds);
}

// The image's data must hold height rows of `step` bytes, each at least width * pixel size: a
// malformed message must not make cv_bridge read past its buffer.
Status checkImageLayout(const sensor_msgs::Image& msg, const std::string& what) {
  if (msg.width == 0 || msg.height == 0) return Status::Error(what + ": empty image (0 pixels)");
  int pixel_bytes = 0;
  try {
    pixel_bytes = enc::bitDepth(msg.encoding) / 8 * enc::numChannels(msg.encoding);
  } catch (const std::exception&) {
    return Status::Error(what + ": unknown encoding '" + msg.encoding + "'");
  }
  if (pixel_bytes <= 0) {
    return Status::Error(what + ": encoding '" + msg.encoding + "' has no pixel size");
  }
  const uint64_t min_step = static_cast<uint64_t>(msg.width) * static_cast<uint64_t>(pixel_bytes);
  if (msg.step < min_step) {
    return Status::Error(what + ": step " + std::to_string(msg.step) + " is smaller than width " +
                         std::to_string(msg.width) + " x " + std::to_string(pixel_bytes) +
                         " bytes");
  }
  if (msg.data.size() < static_cast<uint64_t>(msg.step) * msg.height) {
    return Status::Error(what + ": data holds " + std::to_string(msg.data.size()) +
                         " bytes, step x height needs " +
                         std::to_string(static_cast<uint64_t>(msg.step) * msg.height));
  }
  return Status::Ok();
}

bool isColorEncoding(const std::string& encoding) {
  return encoding == enc::BGR8 || encoding == enc::RGB8;
}

bool isDepthEncoding(const std::string& encoding) {
  return encoding == enc::TYPE_16UC1 || encoding == enc::MONO16 || encoding == enc::TYPE_32FC1;
}

Status copyImage(const sensor_msgs::Image& msg, const std::string& what,
                 const std::string& target_encoding, cv::Mat* image) {
  try {
    cv_bridge::CvImagePtr copy = cv_bridge::toCvCopy(msg, target_encoding);
    *image = copy->image;
  } catch (const std::exception& e) {
    return Status::Error(what + ": cv_bridge cannot convert '" + msg.encoding + "': " + e.what());
  }
  return Status::Ok();
}

// A proper rotation (det +1) from the box axes, for quaternions.
Eigen::Matrix3d properRotation(const Eigen::Matrix3d& axes) {
  Eigen::Matrix3d R = axes;
  if (R.determinant() < 0.0) R.col(1) = -R.col(1);
  // Re-orthonormalise against rounding.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  return svd.matrixU() * svd.matrixV().transpose();
}

}  // namespace

std::string describeInput(const std::string& topic, const std_msgs::Header& header) {
  return "'" + topic + "' (frame '" + header.frame_id + "', stamp " + stampText(header.stamp) + ")";
}

Status colorImageFromMsg(const sensor_msgs::Image& msg, const std::string& topic, cv::Mat* bgr) {
  const std::string what = describeInput(topic, msg.header);
  if (!isColorEncoding(msg.encoding)) {
    return Status::Error(what + ": encoding '" + msg.encoding +
                         "' is not supported for the colour image (use bgr8 or rgb8)");
  }
  const Status layout = checkImageLayout(msg, what);
  if (!layout) return layout;
  return copyImage(msg, what, enc::BGR8, bgr);
}

Status depthImageFromMsg(const sensor_msgs::Image& msg, const std::string& topic, cv::Mat* depth) {
  const std::string what = describeInput(topic, msg.header);
  if (!isDepthEncoding(msg.encoding)) {
    return Status::Error(what + ": encoding '" + msg.encoding +
                         "' is not supported for depth (use 16UC1 in mm or 32FC1 in m)");
  }
  const Status layout = checkImageLayout(msg, what);
  if (!layout) return layout;
  const std::string target = msg.encoding == enc::TYPE_32FC1 ? enc::TYPE_32FC1 : enc::TYPE_16UC1;
  // mono16 and 16UC1 are the same bytes; cv_bridge converts mono16 -> 16UC1 as a plain copy.
  sensor_msgs::Image relabelled;
  const sensor_msgs::Image* source = &msg;
  if (msg.encoding == enc::MONO16) {
    relabelled = msg;
    relabelled.encoding = enc::TYPE_16UC1;
    source = &relabelled;
  }
  return copyImage(*source, what, target, depth);
}

Status intrinsicsFromCameraInfo(const sensor_msgs::CameraInfo& msg, const std::string& topic,
                                CameraIntrinsics* intrinsics) {
  const std::string what = describeInput(topic, msg.header);
  bool all_zero = true;
  for (const double k : msg.K) {
    if (!std::isfinite(k)) return Status::Error(what + ": camera_info K has a non-finite value");
    if (k != 0.0) all_zero = false;
  }
  if (all_zero) {
    return Status::Error(what + ": camera_info K is all zero (camera not calibrated)");
  }
  // image_geometry's K of the image as published: binning and a region of interest applied.
  image_geometry::PinholeCameraModel model;
  try {
    model.fromCameraInfo(msg);
  } catch (const std::exception& e) {
    return Status::Error(what + ": camera_info is not a valid pinhole model: " + e.what());
  }
  const cv::Matx33d& K_image = model.intrinsicMatrix();
  const cv::Size size = model.reducedResolution();
  CameraIntrinsics K;
  K.fx = K_image(0, 0);
  K.fy = K_image(1, 1);
  K.cx = K_image(0, 2);
  K.cy = K_image(1, 2);
  K.width = size.width;
  K.height = size.height;
  if (!K.isValid()) {
    return Status::Error(what + ": camera_info K has fx " + std::to_string(K.fx) + ", fy " +
                         std::to_string(K.fy) + " (need fx, fy > 0)");
  }
  *intrinsics = K;
  return Status::Ok();
}

std::string distortionWarning(const sensor_msgs::CameraInfo& msg, const std::string& topic) {
  const bool distorted = std::any_of(msg.D.begin(), msg.D.end(), [](double d) { return d != 0.0; });
  if (!distorted) return "";
  std::ostringstream coefficients;
  coefficients.precision(4);
  for (size_t i = 0; i < msg.D.size(); ++i) coefficients << (i > 0 ? ", " : "") << msg.D[i];
  return describeInput(topic, msg.header) + ": camera_info has non-zero distortion (" +
         (msg.distortion_model.empty() ? std::string("model unnamed") : msg.distortion_model) +
         " D = [" + coefficients.str() +
         "]); the node uses K only and expects rectified images: subscribe it to image_proc's "
         "rgb/image_rect_color and depth_image_proc's depth_registered/image_rect";
}

namespace {

// The intrinsics a camera_info gave, against the image it came with (checkIntrinsicsForImage: the
// check of the offline tools' intrinsics files too).
Status checkCameraInfoForImage(const CameraIntrinsics& K, const sensor_msgs::Image& image,
                               const sensor_msgs::CameraInfo& info, const std::string& topic) {
  const Status status =
      checkIntrinsicsForImage(K, static_cast<int>(image.width), static_cast<int>(image.height));
  if (status) return status;
  return Status::Error(describeInput(topic, info.header) + ": " + status.message());
}

}  // namespace

Status checkRgbdMessages(const RgbdMessages& msgs, const RgbdTopics& topics) {
  if (!msgs.color || !msgs.depth || !msgs.color_info) {
    return Status::Error("incomplete RGB-D input (colour, depth or camera_info missing)");
  }
  const sensor_msgs::Image& color = *msgs.color;
  const sensor_msgs::Image& depth = *msgs.depth;
  const std::string color_what = describeInput(topics.color, color.header);
  const std::string depth_what = describeInput(topics.depth, depth.header);
  if (!isColorEncoding(color.encoding)) {
    return Status::Error(color_what + ": encoding '" + color.encoding +
                         "' is not supported for the colour image (use bgr8 or rgb8)");
  }
  if (!isDepthEncoding(depth.encoding)) {
    return Status::Error(depth_what + ": encoding '" + depth.encoding +
                         "' is not supported for depth (use 16UC1 in mm or 32FC1 in m)");
  }
  Status status = checkImageLayout(color, color_what);
  if (!status) return status;
  if (!(status = checkImageLayout(depth, depth_what))) return status;

  CameraIntrinsics K_color;
  if (!(status = intrinsicsFromCameraInfo(*msgs.color_info, topics.color_info, &K_color))) {
    return status;
  }
  if (msgs.color_info->width != 0 &&
      (msgs.color_info->width != color.width || msgs.color_info->height != color.height)) {
    return Status::Error(describeInput(topics.color_info, msgs.color_info->header) + ": is for " +
                         sizeText(msgs.color_info->width, msgs.color_info->height) + " but " +
                         color_what + " is " + sizeText(color.width, color.height));
  }
  if (!(status = checkCameraInfoForImage(K_color, color, *msgs.color_info, topics.color_info))) {
    return status;
  }
  if (!msgs.depth_info) {
    if (color.width != depth.width || color.height != depth.height) {
      return Status::Error("mismatched image sizes: " + color_what + " is " +
                           sizeText(color.width, color.height) + " but " + depth_what + " is " +
                           sizeText(depth.width, depth.height) +
                           " (registered depth must have the colour image's size; for "
                           "unregistered depth set depth_registered false)");
    }
    return Status::Ok();
  }
  CameraIntrinsics K_depth;
  if (!(status = intrinsicsFromCameraInfo(*msgs.depth_info, topics.depth_info, &K_depth))) {
    return status;
  }
  if (msgs.depth_info->width != 0 &&
      (msgs.depth_info->width != depth.width || msgs.depth_info->height != depth.height)) {
    return Status::Error(describeInput(topics.depth_info, msgs.depth_info->header) + ": is for " +
                         sizeText(msgs.depth_info->width, msgs.depth_info->height) + " but " +
                         depth_what + " is " + sizeText(depth.width, depth.height));
  }
  return checkCameraInfoForImage(K_depth, depth, *msgs.depth_info, topics.depth_info);
}

Status rgbdFrameFromMsgs(const RgbdMessages& msgs, const RgbdTopics& topics,
                         const Eigen::Isometry3d& T_W_C, const Eigen::Isometry3d& T_C_D,
                         RgbdFrame* frame) {
  Status status = checkRgbdMessages(msgs, topics);
  if (!status) return status;
  RgbdFrame out;
  out.name = "frame at stamp " + stampText(msgs.color->header.stamp);
  out.stamp_s = msgs.color->header.stamp.toSec();
  if (!(status = colorImageFromMsg(*msgs.color, topics.color, &out.color_bgr))) return status;
  if (!(status = depthImageFromMsg(*msgs.depth, topics.depth, &out.depth))) return status;
  if (!(status = intrinsicsFromCameraInfo(*msgs.color_info, topics.color_info, &out.K_color))) {
    return status;
  }
  out.registered = !msgs.depth_info;
  if (out.registered) {
    out.K_depth = out.K_color;
    out.T_C_D = Eigen::Isometry3d::Identity();
  } else {
    if (!(status = intrinsicsFromCameraInfo(*msgs.depth_info, topics.depth_info, &out.K_depth))) {
      return status;
    }
    out.T_C_D = T_C_D;
  }
  out.T_W_D = T_W_C * out.T_C_D;
  if (!(status = out.validate())) return status;
  *frame = std::move(out);
  return Status::Ok();
}

sensor_msgs::ImagePtr colorImageToMsg(const cv::Mat& bgr, const std_msgs::Header& header) {
  return cv_bridge::CvImage(header, enc::BGR8, bgr).toImageMsg();
}

Status poseFromMsg(const geometry_msgs::Pose& msg, Eigen::Isometry3d* T) {
  const Eigen::Vector3d t(msg.position.x, msg.position.y, msg.position.z);
  const Eigen::Quaterniond q(msg.orientation.w, msg.orientation.x, msg.orientation.y,
                             msg.orientation.z);
  if (!t.allFinite() || !q.coeffs().allFinite()) {
    return Status::Error("pose has a NaN or infinite value");
  }
  const double norm = q.norm();
  if (std::abs(norm - 1.0) > kQuaternionNormTolerance) {
    return Status::Error("pose quaternion has norm " + std::to_string(norm) + " (must be 1)");
  }
  geometry_msgs::Pose unit = msg;  // tf2_eigen takes the quaternion as it is
  unit.orientation.w /= norm;
  unit.orientation.x /= norm;
  unit.orientation.y /= norm;
  unit.orientation.z /= norm;
  tf2::fromMsg(unit, *T);
  return Status::Ok();
}

Status transformFromMsg(const geometry_msgs::Transform& msg, Eigen::Isometry3d* T) {
  geometry_msgs::Pose pose;
  pose.position.x = msg.translation.x;
  pose.position.y = msg.translation.y;
  pose.position.z = msg.translation.z;
  pose.orientation = msg.rotation;
  return poseFromMsg(pose, T);
}

geometry_msgs::Pose boxPoseToMsg(const OrientedBox& box) {
  Eigen::Isometry3d T_B = Eigen::Isometry3d::Identity();
  T_B.linear() = box.rotation;
  T_B.translation() = box.center_m;
  return poseToMsg(T_B);
}

geometry_msgs::Vector3 boxSizeToMsg(const OrientedBox& box) {
  geometry_msgs::Vector3 size;
  size.x = box.size_m.x();
  size.y = box.size_m.y();
  size.z = box.size_m.z();
  return size;
}

geometry_msgs::Pose poseToMsg(const Eigen::Isometry3d& T) {
  Eigen::Isometry3d proper = T;
  proper.linear() = properRotation(T.linear());
  return tf2::toMsg(proper);
}

geometry_msgs::Transform transformToMsg(const Eigen::Isometry3d& T) {
  Eigen::Isometry3d proper = T;
  proper.linear() = properRotation(T.linear());
  return tf2::eigenToTransform(proper).transform;
}

namespace {

// The message's arrays agree in length, and the image size is known.
Status checkDetectionsLayout(const multiview_object_detection::InstanceDetections& msg,
                             const cv::Size& image_size, const std::string& what) {
  const size_t n = msg.boxes.size();
  if (msg.scores.size() != n) {
    return Status::Error(what + ": " + std::to_string(n) + " boxes but " +
                         std::to_string(msg.scores.size()) + " scores");
  }
  if (!msg.class_ids.empty() && msg.class_ids.size() != n) {
    return Status::Error(what + ": " + std::to_string(n) + " boxes but " +
                         std::to_string(msg.class_ids.size()) + " class_ids");
  }
  if (!msg.class_names.empty() && msg.class_names.size() != n) {
    return Status::Error(what + ": " + std::to_string(n) + " boxes but " +
                         std::to_string(msg.class_names.size()) + " class_names");
  }
  if (n > 0 && msg.class_ids.empty() && msg.class_names.empty()) {
    return Status::Error(what + ": neither class_ids nor class_names are given");
  }
  if (!msg.masks.empty() && msg.masks.size() != n) {
    return Status::Error(what + ": " + std::to_string(n) + " boxes but " +
                         std::to_string(msg.masks.size()) +
                         " masks (give one mask per box, or none)");
  }
  if (image_size.width <= 0 || image_size.height <= 0) {
    return Status::Error(what + ": the image size is unknown");
  }
  return Status::Ok();
}

// Scores first: a probability outside [0, 1] (a detector publishing percentages) is refused, and
// only the max_detections highest-scoring detections are converted, so one huge message costs
// bounded memory and time. The indices kept, in message order.
std::vector<size_t> detectionsToConvert(const multiview_object_detection::InstanceDetections& msg,
                                        const std::string& what, size_t max_detections,
                                        std::vector<std::string>* warnings, size_t* capped) {
  const size_t n = msg.boxes.size();
  std::vector<size_t> kept;
  kept.reserve(std::min(n, max_detections + 1));
  for (size_t i = 0; i < n; ++i) {
    const float score = msg.scores[i];
    if (!(score >= 0.f && score <= 1.f)) {
      if (warnings != nullptr) {
        warnings->push_back(what + ": detection " + std::to_string(i) + ": score " +
                            std::to_string(score) +
                            " is not a probability in [0, 1] (percentages?), skipped");
      }
      continue;
    }
    kept.push_back(i);
  }
  if (kept.size() > max_detections) {
    std::stable_sort(kept.begin(), kept.end(),
                     [&msg](size_t a, size_t b) { return msg.scores[a] > msg.scores[b]; });
    if (warnings != nullptr) {
      warnings->push_back(what + ": " + std::to_string(kept.size()) + " detections; only the " +
                          std::to_string(max_detections) +
                          " highest-scoring are used (max_detections_per_frame)");
    }
    if (capped != nullptr) *capped = kept.size() - max_detections;
    kept.resize(max_detections);
    std::sort(kept.begin(), kept.end());  // message order
  }
  return kept;
}

// Detection i of the message; a reason to skip it otherwise (warning text without the label).
bool detectionFromMsg(const multiview_object_detection::InstanceDetections& msg, size_t i,
                      const cv::Size& image_size, const std::string& label, Detection2D* detection,
                      std::string* problem) {
  const std::vector<std::string>& coco = cocoClassNames();
  const cv::Rect image_rect(0, 0, image_size.width, image_size.height);
  detection->score = msg.scores[i];
  const int id = msg.class_ids.empty() ? -1 : msg.class_ids[i];
  const std::string name = msg.class_names.empty() ? std::string() : msg.class_names[i];
  if (id >= 0 && id < static_cast<int>(coco.size())) {
    detection->class_id = id;
    detection->class_name = coco[id];
  } else {
    // The mapper reports names it cannot place.
    detection->class_id = cocoClassId(name);
    detection->class_name = name;
  }
  const sensor_msgs::RegionOfInterest& roi = msg.boxes[i];
  const cv::Rect box = cv::Rect(static_cast<int>(std::min<uint32_t>(roi.x_offset, 1u << 30)),
                                static_cast<int>(std::min<uint32_t>(roi.y_offset, 1u << 30)),
                                static_cast<int>(std::min<uint32_t>(roi.width, 1u << 30)),
                                static_cast<int>(std::min<uint32_t>(roi.height, 1u << 30))) &
                       image_rect;
  if (box.area() <= 0) {
    *problem = "box lies outside the " + sizeText(image_size.width, image_size.height) + " image";
    return false;
  }
  detection->box_px = box;
  if (msg.masks.empty()) {
    detection->mask = cv::Mat(box.size(), CV_8UC1, cv::Scalar(255));
    return true;
  }
  const sensor_msgs::Image& mask_msg = msg.masks[i];
  if (mask_msg.encoding != enc::MONO8 && mask_msg.encoding != enc::TYPE_8UC1) {
    *problem = "mask encoding '" + mask_msg.encoding + "' (expected mono8)";
    return false;
  }
  if (static_cast<int>(mask_msg.width) != image_size.width ||
      static_cast<int>(mask_msg.height) != image_size.height) {
    *problem = "mask is " + sizeText(mask_msg.width, mask_msg.height) + ", the image " +
               sizeText(image_size.width, image_size.height);
    return false;
  }
  const Status layout = checkImageLayout(mask_msg, label + " mask");
  if (!layout) {
    *problem = layout.message();
    return false;
  }
  // Only the box's pixels are kept (Detection2D's box-sized mask).
  cv::Mat mask(box.size(), CV_8UC1);
  for (int r = 0; r < box.height; ++r) {
    std::memcpy(mask.ptr<uint8_t>(r),
                &mask_msg.data[static_cast<size_t>(r + box.y) * mask_msg.step + box.x],
                static_cast<size_t>(box.width));
  }
  if (cv::countNonZero(mask) == 0) {
    *problem = "mask is empty";
    return false;
  }
  detection->mask = mask;
  return true;
}

}  // namespace

Status detectionsFromMsg(const multiview_object_detection::InstanceDetections& msg,
                         const cv::Size& image_size, const std::string& topic,
                         std::vector<Detection2D>* detections, std::vector<std::string>* warnings,
                         size_t max_detections, size_t* capped) {
  if (capped != nullptr) *capped = 0;
  const std::string what = describeInput(topic, msg.header);
  const Status layout = checkDetectionsLayout(msg, image_size, what);
  if (!layout) return layout;
  const std::vector<size_t> kept = detectionsToConvert(msg, what, max_detections, warnings, capped);
  std::vector<Detection2D> out;
  out.reserve(kept.size());
  for (const size_t i : kept) {
    const std::string label = what + ": detection " + std::to_string(i);
    Detection2D detection;
    std::string problem;
    if (detectionFromMsg(msg, i, image_size, label, &detection, &problem)) {
      out.push_back(std::move(detection));
    } else if (warnings != nullptr) {
      // The image layout check names the mask itself.
      const bool named = problem.rfind(label, 0) == 0;
      warnings->push_back((named ? problem : label + ": " + problem) + ", skipped");
    }
  }
  *detections = std::move(out);
  return Status::Ok();
}

multiview_object_detection::InstanceDetections detectionsToMsg(
    const std::vector<Detection2D>& detections, const cv::Size& image_size,
    const std_msgs::Header& header, bool include_masks) {
  multiview_object_detection::InstanceDetections msg;
  msg.header = header;
  bool all_masks = include_masks;
  for (const Detection2D& d : detections) {
    cv::Point origin;
    if (!maskOrigin(d, image_size, &origin)) all_masks = false;
  }
  for (const Detection2D& d : detections) {
    sensor_msgs::RegionOfInterest roi;
    roi.x_offset = static_cast<uint32_t>(std::max(0, d.box_px.x));
    roi.y_offset = static_cast<uint32_t>(std::max(0, d.box_px.y));
    roi.width = static_cast<uint32_t>(std::max(0, d.box_px.width));
    roi.height = static_cast<uint32_t>(std::max(0, d.box_px.height));
    msg.boxes.push_back(roi);
    msg.class_ids.push_back(d.class_id);
    msg.class_names.push_back(d.class_name);
    msg.scores.push_back(d.score);
    if (all_masks) {
      const cv::Mat mask = maskInRegion(d, image_size, cv::Rect(cv::Point(0, 0), image_size));
      msg.masks.push_back(*cv_bridge::CvImage(header, enc::MONO8, mask).toImageMsg());
    }
  }
  return msg;
}

multiview_object_detection::Object objectToMsg(const MapObject& object) {
  multiview_object_detection::Object msg;
  msg.id = object.id;
  msg.class_id = object.class_id;
  msg.class_name = object.class_name;
  msg.probability = static_cast<float>(object.probability);
  msg.observations = object.observations;
  msg.pose = boxPoseToMsg(object.box);
  msg.size = boxSizeToMsg(object.box);
  msg.yaw = static_cast<float>(object.yaw_rad);
  msg.box_completed = object.box_completed;
  msg.existence = static_cast<float>(object.existence.probability());
  msg.views_detected = object.existence.detected;
  msg.views_missed = object.existence.missed;
  msg.views_seen_through = object.existence.seen_through;
  msg.num_points = static_cast<int32_t>(object.segment_W.empty() ? object.points_W.size()
                                                                 : object.segment_W.size());
  msg.first_seen = timeFromSeconds(object.first_seen_s);
  msg.last_seen = timeFromSeconds(object.last_seen_s);
  return msg;
}

Status objectFromMsg(const multiview_object_detection::Object& msg, MapObject* object) {
  Eigen::Isometry3d T_W_B;
  const Status pose = poseFromMsg(msg.pose, &T_W_B);
  if (!pose) return Status::Error("object " + std::to_string(msg.id) + ": " + pose.message());
  const Eigen::Vector3d size(msg.size.x, msg.size.y, msg.size.z);
  if (!size.allFinite() || (size.array() < 0.0).any()) {
    return Status::Error("object " + std::to_string(msg.id) + ": size must be finite and >= 0");
  }
  MapObject out;
  out.id = msg.id;
  out.class_id = msg.class_id;
  out.class_name = msg.class_name;
  out.probability = msg.probability;
  out.observations = msg.observations;
  out.box.center_m = T_W_B.translation();
  out.box.rotation = T_W_B.linear();
  out.box.size_m = size;
  out.yaw_rad = msg.yaw;
  out.box_completed = msg.box_completed;
  out.observed_box = out.box;  // the message carries no observed part: the box stands in
  out.first_seen_s = msg.first_seen.toSec();
  out.last_seen_s = msg.last_seen.toSec();
  if (std::isfinite(msg.existence) && msg.existence > 0.f && msg.existence < 1.f) {
    out.existence.log_odds = std::log(msg.existence / (1.0 - msg.existence));
  }
  out.existence.detected = msg.views_detected;
  out.existence.missed = msg.views_missed;
  out.existence.seen_through = msg.views_seen_through;
  *object = std::move(out);
  return Status::Ok();
}

multiview_object_detection::ObjectArray objectsToMsg(const std::vector<MapObject>& objects,
                                                     const std_msgs::Header& header) {
  multiview_object_detection::ObjectArray msg;
  msg.header = header;
  msg.objects.reserve(objects.size());
  for (const MapObject& object : objects) msg.objects.push_back(objectToMsg(object));
  return msg;
}

}  // namespace mvod
