// Chooses a deployable InstanceSegmenter backend by name: "files" (precomputed JSON + PNG masks),
// "yolo_seg", "fastestdet" or "maskrcnn" (OpenCV DNN). The benchmark's "simulated" detector lives
// in the evaluation library (evaluation/benchmark_segmenter_factory.h), which the node does not
// link.
#pragma once

#include <memory>
#include <string>

#include "multiview_object_detection/pipeline/types/detection.h"

namespace mvod {

// Each detector's thresholds, chosen on real frames (docs/parameters.md, "Detector thresholds"):
// a weak detector's scores are low where its classes are hard (YOLOv5n-seg scores the redkitchen's
// table 0.15-0.35), so one number for every detector leaves some of them with an empty map.
// Multi-view evidence, not the per-frame score, then decides what stays (the existence evidence
// removes what is detected once and missed after).
struct DetectorThresholds {
  float score_threshold;   // what the detector reports (its overlays, ~detections_image)
  float nms_threshold;     // same-class boxes overlapping more are one (FastestDet, YOLOv5-seg)
  float mask_threshold;    // mask probability -> binary (Mask R-CNN, YOLOv5-seg)
  double min_probability;  // λ of Eq. 5: what the mapper maps
};
// files, topic (external detectors) and simulated: λ 0.5, no score threshold of their own.
DetectorThresholds detectorThresholds(const std::string& detector);
// A threshold option left at this: the detector's own (detectorThresholds).
constexpr float kDetectorDefault = -1.f;

struct SegmenterOptions {
  std::string detector = "files";  // files | yolo_seg | fastestdet | maskrcnn
  // files: folder of frame-NNNNNN.json; simulated (benchmark only): the sequence folder.
  std::string detections_dir;
  // Folder searched for model files given without a directory; empty = $MVOD_MODEL_DIR, else
  // defaultModelDirectory().
  std::string model_dir;
  std::string maskrcnn_weights = "frozen_inference_graph.pb";
  std::string maskrcnn_graph = "mask_rcnn_inception_v2_coco_2018_01_28.pbtxt";
  std::string maskrcnn_labels = "object_detection_classes_coco.txt";
  std::string fastestdet_model = "FastestDet.onnx";
  std::string fastestdet_labels = "coco.names";
  // YOLOv5-seg: any export of the official layout (yolov5n/s/m-seg, at 640 or 320).
  std::string yolo_seg_model = "yolov5n-seg.onnx";
  std::string yolo_seg_labels = "coco.names";
  int yolo_seg_input_px = 0;  // 0 = the size the ONNX file declares
  // The DNN detectors: detections below are not reported (λ is applied again by the mapper).
  // kDetectorDefault: the detector's own (detectorThresholds), here and in the two below.
  float score_threshold = kDetectorDefault;
  float nms_threshold = kDetectorDefault;   // FastestDet, YOLOv5-seg
  float mask_threshold = kDetectorDefault;  // Mask R-CNN, YOLOv5-seg: mask probability -> binary
  std::string backend = "cpu";              // cpu | cuda (needs an OpenCV built with CUDA)
  // files: at most this many detections per frame (the highest scores), with a warning.
  int max_detections = 100;
  Status isValid() const;
  // The thresholds left at kDetectorDefault set to the detector's own.
  SegmenterOptions withDetectorDefaults() const;
  // The checks shared with the benchmark's options: thresholds and backend, not the name.
  Status isValidExceptDetector() const;
};

// On failure (unknown name, missing or corrupt model files) the message says what is missing and
// how to get it; *segmenter is left empty.
Status createInstanceSegmenter(const SegmenterOptions& options,
                               std::unique_ptr<InstanceSegmenter>* segmenter);

// Where model files are looked for when neither model_dir nor $MVOD_MODEL_DIR is set:
// $ROS_HOME/multiview_object_detection/models ($HOME/.ros/... without ROS_HOME), the folder
// scripts/download_models.sh writes to. Empty when neither variable is set.
std::string defaultModelDirectory();
// The model folder in use: options.model_dir, else $MVOD_MODEL_DIR, else defaultModelDirectory().
std::string modelDirectory(const SegmenterOptions& options);
// Resolves a model file name against modelDirectory(options) (absolute paths are kept).
std::string resolveModelPath(const SegmenterOptions& options, const std::string& file);

// "auto": the best detector whose model file is in the model folder (yolo_seg, an instance
// segmenter, before fastestdet, a box detector); fastestdet when neither file is there (its
// creation then says what is missing). Any other name is returned as it is.
std::string resolveAutoDetector(const SegmenterOptions& options);

// The "class score" labels of detections on an image: one rectangle per detection, in order, at
// the free spot nearest its box's top-left corner, with its text and the font's baseline.
struct DetectionLabels {
  std::vector<cv::Rect> spots;
  std::vector<std::string> texts;
  int baseline = 0;
};
DetectionLabels layoutDetectionLabels(const std::vector<Detection2D>& detections,
                                      const cv::Size& image_size);

// Draws tinted masks, boxes and "class score" labels on a copy of the image, for people to look at.
cv::Mat drawDetections(const cv::Mat& image_bgr, const std::vector<Detection2D>& detections);
// The same with the labels laid out already (layoutDetectionLabels on this image's size), for a
// caller that keeps its own drawings clear of them.
cv::Mat drawDetections(const cv::Mat& image_bgr, const std::vector<Detection2D>& detections,
                       const DetectionLabels& labels);

}  // namespace mvod
