// 2D instance detections and the interface every detector backend implements.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/common.h"

namespace mvod {

// One instance in a colour image. mask is CV_8UC1 with the colour image's size, non-zero = object; a detector
// that only gives boxes fills the box.
struct Detection2D {
  int class_id = -1;  // index into cocoClassNames(), -1 when unknown
  std::string class_name;
  float score = 0.f;
  cv::Rect box_px;
  cv::Mat mask;
};

// Colour image -> instance detections. Implementations: FileInstanceSegmenter (precomputed JSON + PNG masks);
// the OpenCV DNN backends live in their own files.
class InstanceSegmenter {
 public:
  virtual ~InstanceSegmenter() = default;
  // frame_name identifies the frame for backends that read precomputed results (e.g. "frame-000010").
  // Detections of classes the segmenter cannot name are dropped and reported through `warnings`.
  virtual Status detect(const cv::Mat& image_bgr, const std::string& frame_name,
                        std::vector<Detection2D>* detections,
                        std::vector<std::string>* warnings = nullptr) = 0;
  virtual std::string name() const = 0;
};

}  // namespace mvod
