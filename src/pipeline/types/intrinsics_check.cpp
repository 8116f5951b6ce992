#include "multiview_object_detection/pipeline/types/intrinsics_check.h"

#include <cmath>
#include <cstdio>
#include <string>

#include "multiview_object_detection/pipeline/types/rgbd_frame.h"

namespace mvod {
namespace {

std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", value);
  return text;
}

// The angle (degrees) that pixels [0, size] span, seen through focal length f and principal point
// c.
double fieldOfViewDeg(double f, double c, int size) {
  return (std::atan(c / f) + std::atan((size - c) / f)) * 180.0 / M_PI;
}

}  // namespace

Status checkIntrinsicsForImage(const CameraIntrinsics& K, int width, int height) {
  if (width <= 0 || height <= 0) return Status::Error("empty image " + sizeText(width, height));
  if ((K.width > 0 || K.height > 0) && (K.width != width || K.height != height)) {
    return Status::Error("intrinsics are for " + sizeText(K.width, K.height) +
                         " but the image is " + sizeText(width, height));
  }
  if (!(K.fx > 0.0 && K.fy > 0.0 && std::isfinite(K.fx) && std::isfinite(K.fy))) {
    return Status::Error("focal lengths fx " + number(K.fx) + ", fy " + number(K.fy) +
                         " px (need fx, fy > 0)");
  }
  if (!(K.cx >= 0.0 && K.cx <= width && K.cy >= 0.0 && K.cy <= height)) {
    return Status::Error("principal point (" + number(K.cx) + ", " + number(K.cy) +
                         ") px is outside the " + sizeText(width, height) + " image");
  }
  const double horizontal_deg = fieldOfViewDeg(K.fx, K.cx, width);
  const double vertical_deg = fieldOfViewDeg(K.fy, K.cy, height);
  if (!(horizontal_deg >= kMinHorizontalFovDeg && horizontal_deg <= kMaxHorizontalFovDeg &&
        vertical_deg >= kMinVerticalFovDeg && vertical_deg <= kMaxVerticalFovDeg)) {
    return Status::Error(
        "fx " + number(K.fx) + ", fy " + number(K.fy) + " px on the " + sizeText(width, height) +
        " image give a field of view of " + number(std::round(horizontal_deg * 10.0) / 10.0) +
        " x " + number(std::round(vertical_deg * 10.0) / 10.0) + " degrees; an RGB-D camera has " +
        number(kMinHorizontalFovDeg) + "-" + number(kMaxHorizontalFovDeg) + " x " +
        number(kMinVerticalFovDeg) + "-" + number(kMaxVerticalFovDeg) +
        " (a wrong or another camera's calibration?)");
  }
  return Status::Ok();
}

}  // namespace mvod
