// What the OpenCV DNN decoders share (not installed; the detectors library's own).
#pragma once

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <string>

#include "multiview_object_detection/pipeline/types/class_priors.h"
#include "multiview_object_detection/pipeline/types/detection.h"

namespace mvod {
namespace detector_common {

// Label files spell some classes differently (darknet's coco.names: "diningtable", "tvmonitor");
// outputs always carry this package's COCO spelling, or the label as it is when it is no COCO
// class.
inline void setClass(const std::string& label, Detection2D* detection) {
  detection->class_id = cocoClassId(label);
  detection->class_name = detection->class_id >= 0 ? cocoClassNames()[detection->class_id] : label;
}

// The pixels a box of corners (x1, y1), (x2, y2) covers, clipped to the image.
inline cv::Rect clippedBox(double x1, double y1, double x2, double y2, const cv::Size& image_size) {
  const int left = std::clamp(static_cast<int>(std::floor(x1)), 0, image_size.width);
  const int top = std::clamp(static_cast<int>(std::floor(y1)), 0, image_size.height);
  const int right = std::clamp(static_cast<int>(std::ceil(x2)), 0, image_size.width);
  const int bottom = std::clamp(static_cast<int>(std::ceil(y2)), 0, image_size.height);
  return cv::Rect(left, top, std::max(0, right - left), std::max(0, bottom - top));
}

}  // namespace detector_common
}  // namespace mvod
