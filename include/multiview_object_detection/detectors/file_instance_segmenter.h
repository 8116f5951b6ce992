// Detections precomputed by any model, read from `<dir>/<frame_name>.json`:
//   [{"class_name": "chair", "score": 0.9, "box": [x1, y1, x2, y2], "mask": "frame-000010.0.png"}]
// "mask" (optional) is a PNG relative to the folder, non-zero = object, the colour image's size; without it
// the box is the mask. Boxes are colour-image pixels, x2/y2 exclusive (cv::Rect(x1, y1, x2 - x1, y2 - y1)),
// clipped to the image. A frame without a JSON file has no detections; a broken document is an error,
// a bad entry a warning (that entry is skipped).
#pragma once

#include "multiview_object_detection/pipeline/detection.h"

namespace mvod {

class FileInstanceSegmenter : public InstanceSegmenter {
 public:
  explicit FileInstanceSegmenter(std::string directory) : directory_(std::move(directory)) {}
  Status detect(const cv::Mat& image_bgr, const std::string& frame_name,
                std::vector<Detection2D>* detections,
                std::vector<std::string>* warnings = nullptr) override;
  std::string name() const override { return "files"; }

  // Writes detections in the same format (masks as PNGs next to the JSON).
  static Status write(const std::string& directory, const std::string& frame_name,
                      const std::vector<Detection2D>& detections);

 private:
  std::string directory_;
};

}  // namespace mvod
