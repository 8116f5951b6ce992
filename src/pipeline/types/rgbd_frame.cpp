#include "multiview_object_detection/pipeline/types/rgbd_frame.h"

#include <string>

#include "multiview_object_detection/pipeline/types/map_limits.h"

namespace mvod {

std::string matTypeName(const cv::Mat& m) {
  static const char* const kDepthNames[] = {"8U", "8S", "16U", "16S", "32S", "32F", "64F", "16F"};
  return std::string(kDepthNames[m.depth()]) + "C" + std::to_string(m.channels());
}

std::string sizeText(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

namespace {

// Intrinsics must be usable and, when they say which image size they belong to, agree with the
// image.
Status checkIntrinsics(const std::string& label, const char* which, const CameraIntrinsics& K,
                       const cv::Mat& image) {
  if (!K.isValid()) {
    return Status::Error(label + ": invalid " + which + " intrinsics (fx " + std::to_string(K.fx) +
                         ", fy " + std::to_string(K.fy) + ", cx " + std::to_string(K.cx) + ", cy " +
                         std::to_string(K.cy) + "; need fx, fy > 0, finite cx, cy)");
  }
  if ((K.width > 0 || K.height > 0) && (K.width != image.cols || K.height != image.rows)) {
    return Status::Error(label + ": " + which + " intrinsics are for " +
                         sizeText(K.width, K.height) + " but the " + which + " image is " +
                         sizeText(image.cols, image.rows));
  }
  return Status::Ok();
}

}  // namespace

Status RgbdFrame::validate() const {
  const std::string label = name.empty() ? "frame " + std::to_string(index) : name;

  if (color_bgr.empty()) return Status::Error(label + ": colour image is empty");
  if (color_bgr.type() != CV_8UC3) {
    return Status::Error(label + ": colour is " + matTypeName(color_bgr) + ", expected 8UC3 (BGR)");
  }
  if (depth.empty()) return Status::Error(label + ": depth image is empty");
  if (depth.type() != CV_16UC1 && depth.type() != CV_32FC1) {
    return Status::Error(label + ": depth is " + matTypeName(depth) +
                         ", expected 16UC1 (mm) or 32FC1 (m)");
  }

  Status status = checkIntrinsics(label, "depth", K_depth, depth);
  if (!status) return status;

  if (registered) {
    // Masks (colour pixels) are looked up at the depth pixel's own (u, v).
    if (color_bgr.size() != depth.size()) {
      return Status::Error(label + ": colour " + sizeText(color_bgr.cols, color_bgr.rows) +
                           " but depth " + sizeText(depth.cols, depth.rows) +
                           " in a registered frame (registered colour and depth must have the "
                           "same size)");
    }
    // K_color is not used when registered; if it names a size, it must still be the colour's.
    if ((K_color.width > 0 || K_color.height > 0) &&
        (K_color.width != color_bgr.cols || K_color.height != color_bgr.rows)) {
      return Status::Error(label + ": colour intrinsics are for " +
                           sizeText(K_color.width, K_color.height) + " but the colour image is " +
                           sizeText(color_bgr.cols, color_bgr.rows));
    }
  } else {
    status = checkIntrinsics(label, "colour", K_color, color_bgr);
    if (!status) return status;
    if (!isValidPose(T_C_D)) {
      return Status::Error(label +
                           ": T_C_D (depth to colour camera) is not a finite rigid transform");
    }
  }

  if (!isValidPose(T_W_D)) {
    return Status::Error(label + ": T_W_D (depth camera to world) is not a finite rigid transform");
  }
  return checkCameraInMap(T_W_D, label + ": the camera");
}

}  // namespace mvod
