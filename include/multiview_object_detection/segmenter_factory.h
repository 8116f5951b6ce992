// Chooses an InstanceSegmenter backend by name: "files" (precomputed JSON + PNG masks),
// "fastestdet", "maskrcnn" (OpenCV DNN) or "simulated" (ground-truth label images of a
// SceneNN-layout sequence with realistic failures, SimulatedInstanceSegmenter).
#pragma once

#include <memory>
#include <string>

#include "multiview_object_detection/detection.h"
#include "multiview_object_detection/simulated_instance_segmenter.h"

namespace mvod {

struct SegmenterOptions {
  std::string detector = "files";  // files | fastestdet | maskrcnn | simulated
  // files: folder of frame-NNNNNN.json; simulated: the sequence folder (<id>.xml, label/).
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
  // simulated: failure rates, scores and seed (its defaults mimic Mask R-CNN on SceneNN).
  SimulatedInstanceSegmenter::Config simulated;
  Status isValid() const;
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
