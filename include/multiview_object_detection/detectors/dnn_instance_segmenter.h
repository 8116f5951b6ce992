// OpenCV DNN detector backends of InstanceSegmenter (Sec. 3.1): Mask R-CNN (TensorFlow Inception v2
// COCO through OpenCV's text graph), YOLOv5-seg (Ultralytics' ONNX export, an instance segmenter of
// the same class; yolo_seg_decoder.h) and FastestDet (a 1 MB COCO box detector whose box becomes
// the mask; LCCP then cuts the object from the background). No Python, PyTorch or TensorFlow at
// run time.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/detection.h"

namespace mvod {

// Reads a label file: one name per line (empty lines kept as empty names so ids stay aligned).
Status readLabelFile(const std::string& path, std::vector<std::string>* labels);

struct DnnDecodeConfig {
  float score_threshold = 0.5f;  // detections below are dropped (λ is applied again by the mapper)
  float nms_threshold = 0.4f;    // IoU above which the weaker of two same-class boxes is dropped
  float mask_threshold = 0.3f;   // Mask R-CNN: mask probability -> binary
};

// FastestDet output [1, 85, H, W] (H = W = 22 for a 352x352 input) -> detections in image pixels.
// Per cell: 0 objectness, 1-2 centre offsets (tanh), 3-4 width/height (sigmoid, normalised),
// 5..84 class scores; score = objectness * max class score; then per-class NMS. class ids index
// `labels` (the 80 COCO names, coco.names order); masks are the filled boxes.
Status decodeFastestDet(const cv::Mat& output, const cv::Size& image_size,
                        const std::vector<std::string>& labels, const DnnDecodeConfig& config,
                        std::vector<Detection2D>* detections);

// Mask R-CNN outputs: detection_out_final [1, 1, N, 7] (batch, class id, score, x1, y1, x2, y2
// normalised) and detection_masks [N, C, h, w] (C = 90 for COCO, one h x w mask per class). Each
// kept detection's mask for its class is resized to its box and thresholded. class ids of the
// output index `labels` (object_detection_classes_coco.txt, 90 lines); Detection2D::class_id is
// then mapped to this package's 80-class COCO ids by name (-1 when the name is not one).
Status decodeMaskRcnn(const cv::Mat& detection_out, const cv::Mat& detection_masks,
                      const cv::Size& image_size, const std::vector<std::string>& labels,
                      const DnnDecodeConfig& config, std::vector<Detection2D>* detections);

struct DnnModelOptions {
  std::string model_path;   // FastestDet, YOLOv5-seg: .onnx; Mask R-CNN: frozen_inference_graph.pb
  std::string config_path;  // Mask R-CNN: the OpenCV text graph (.pbtxt); unused for FastestDet
  std::string labels_path;  // label file
  std::string backend = "cpu";  // cpu | cuda
  DnnDecodeConfig decode;
  // YOLOv5-seg: the network's input side S; 0 = the one the ONNX file declares (640 where it
  // declares none, a dynamic export). A file exported for one size fails on any other.
  int input_px = 0;
};

class DnnInstanceSegmenter : public InstanceSegmenter {
 public:
  enum class Model { kFastestDet, kMaskRcnn, kYoloSeg };
  // Loads the network; a missing or corrupt file gives an error that says which file and how to get
  // it. *segmenter stays empty on failure.
  static Status create(Model model, const DnnModelOptions& options,
                       std::unique_ptr<DnnInstanceSegmenter>* segmenter);
  ~DnnInstanceSegmenter() override;

  Status detect(const cv::Mat& image_bgr, const std::string& frame_name,
                std::vector<Detection2D>* detections,
                std::vector<std::string>* warnings = nullptr) override;
  std::string name() const override;
  const std::vector<std::string>& labels() const { return labels_; }
  // YOLOv5-seg: the input side S in use (0 for the other models).
  int inputPx() const { return input_px_; }

 private:
  DnnInstanceSegmenter(Model model, const DnnModelOptions& options);
  Model model_;
  DnnModelOptions options_;
  std::vector<std::string> labels_;
  int input_px_ = 0;
  struct Network;  // the cv::dnn::Net, kept out of this header
  std::unique_ptr<Network> network_;
};

}  // namespace mvod
