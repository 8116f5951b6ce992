// Detections precomputed by any model, read from `<dir>/<frame_name>.json`:
//   [{"class_name": "chair", "score": 0.9, "box": [x1, y1, x2, y2], "mask": "frame-000010.0.png"}]
// "mask" (optional) is a PNG relative to the folder, non-zero = object, the colour image's size;
// without it the box is the mask. Boxes are colour-image pixels, x2/y2 exclusive (cv::Rect(x1, y1,
// x2 - x1, y2 - y1)), clipped to the image. A frame without a JSON file has no detections; a broken
// document, a path that is not a regular file (a folder, a FIFO) or a file over
// kMaxDetectionFileBytes is an error; a bad entry a warning (that entry is skipped): a score that
// is not a probability in [0, 1] (a detector giving percentages), a mask of another size than the
// colour image (checked from the PNG header, before decoding). At most Config::max_detections are
// kept per frame, the highest scores, with a warning saying how many were dropped: each detection
// costs a full-image mask.
#pragma once

#include <cstdint>

#include "multiview_object_detection/pipeline/types/detection.h"

namespace mvod {

class FileInstanceSegmenter : public InstanceSegmenter {
 public:
  // A detection file above this is refused before it is read.
  static constexpr int64_t kMaxDetectionFileBytes = int64_t{64} << 20;

  struct Config {
    int max_detections = 100;  // per frame; the highest scores are kept
    Status isValid() const;
  };

  explicit FileInstanceSegmenter(std::string directory);
  FileInstanceSegmenter(std::string directory, Config config)
      : directory_(std::move(directory)), config_(config) {}
  Status detect(const cv::Mat& image_bgr, const std::string& frame_name,
                std::vector<Detection2D>* detections,
                std::vector<std::string>* warnings = nullptr) override;
  std::string name() const override { return "files"; }
  const Config& config() const { return config_; }

  // Parses one <frame>.json document (`text`) as detect() does; `source` names it in messages,
  // mask file names are relative to mask_directory, image_size is the colour image's size.
  // Never throws.
  static Status parseDetections(const std::string& text, const std::string& source,
                                const std::string& mask_directory, const cv::Size& image_size,
                                const Config& config, std::vector<Detection2D>* detections,
                                std::vector<std::string>* warnings);

  // Writes detections in the same format (masks as PNGs next to the JSON).
  static Status write(const std::string& directory, const std::string& frame_name,
                      const std::vector<Detection2D>& detections);

 private:
  std::string directory_;
  Config config_;
};

}  // namespace mvod
