// Chooses a deployable InstanceSegmenter backend by name: "files" (precomputed JSON + PNG masks),
// "fastestdet" or "maskrcnn" (OpenCV DNN). The benchmark's "simulated" detector lives in the
// evaluation library (evaluation/benchmark_segmenter_factory.h), which the node does not link.
#pragma once

#include <memory>
#include <string>

#include "multiview_object_detection/pipeline/types/detection.h"

namespace mvod {

struct SegmenterOptions {
  std::string detector = "files";  // files | fastestdet | maskrcnn
  // files: folder of frame-NNNNNN.json; simulated (benchmark only): the sequence folder.
  std::string detections_dir;
  // Folder searched for model files given without a directory; empty = $MVOD_MODEL_DIR.
  std::string model_dir;
  std::string maskrcnn_weights = "frozen_inference_graph.pb";
  std::string maskrcnn_graph = "mask_rcnn_inception_v2_coco_2018_01_28.pbtxt";
  std::string maskrcnn_labels = "object_detection_classes_coco.txt";
  std::string fastestdet_model = "FastestDet.onnx";
  std::string fastestdet_labels = "coco.names";
  // fastestdet / maskrcnn: detections below are not reported (λ is applied again by the mapper).
  float score_threshold = 0.5f;
  float nms_threshold = 0.4f;   // FastestDet
  float mask_threshold = 0.3f;  // Mask R-CNN: mask probability -> binary
  std::string backend = "cpu";  // cpu | cuda (needs an OpenCV built with CUDA)
  // files: at most this many detections per frame (the highest scores), with a warning.
  int max_detections = 100;
  Status isValid() const;
  // The checks shared with the benchmark's options: thresholds and backend, not the name.
  Status isValidExceptDetector() const;
};

// On failure (unknown name, missing or corrupt model files) the message says what is missing and
// how to get it; *segmenter is left empty.
Status createInstanceSegmenter(const SegmenterOptions& options,
                               std::unique_ptr<InstanceSegmenter>* segmenter);

// Resolves a model file name against options.model_dir / $MVOD_MODEL_DIR (absolute paths are kept).
std::string resolveModelPath(const SegmenterOptions& options, const std::string& file);

// Draws tinted masks, boxes and "class score" labels on a copy of the image, for people to look at.
cv::Mat drawDetections(const cv::Mat& image_bgr, const std::vector<Detection2D>& detections);

}  // namespace mvod
