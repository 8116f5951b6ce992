// YOLOv5-seg (Ultralytics v7.0 `export.py --include onnx`) input and output, ROS- and network-free:
// the letterbox that places a colour image in the network's square input, and the decoding of its
// two outputs into instance detections with box-sized masks.
//   input  `images`  [1, 3, S, S] RGB in [0, 1], the image scaled to fit and centred, grey 114
//   around output `output0` [1, N, 5 + C + 32] per anchor: cx, cy, w, h (input pixels), objectness,
//   C class
//                    scores (already sigmoid), 32 mask coefficients; N = 3 (S/8)^2 + 3 (S/16)^2 +
//                    3 (S/32)^2
//   output `output1` [1, 32, S/4, S/4] mask prototypes
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/detection.h"

namespace mvod {

// Where a colour image lies in the network's S x S input, as YOLOv5's letterbox puts it.
struct Letterbox {
  int input_px = 640;  // S
  double scale = 1.0;  // input pixels per image pixel
  cv::Size scaled_px;  // the image's size in the input
  cv::Point pad_px;    // the image's top-left corner in the input
  cv::Size image_px;   // the colour image's size

  static Letterbox fit(const cv::Size& image_size, int input_px);
  // The network input: [1, 3, S, S] float, RGB, values in [0, 1].
  cv::Mat blob(const cv::Mat& image_bgr) const;
};

struct YoloSegDecodeConfig {
  float score_threshold = 0.25f;  // objectness x best class score
  float nms_threshold = 0.45f;    // class-aware: IoU above which the weaker box is dropped
  float mask_threshold = 0.5f;    // mask probability -> binary
  int max_detections = 300;       // kept after NMS, the highest scores
};

// The number of rows N a network of input S gives (its three strides, three anchors each).
int yoloSegRows(int input_px);

// output0 and output1 -> detections in colour-image pixels, highest score first. class ids of the
// output index `labels` (coco.names order); Detection2D::class_id is this package's COCO id of the
// label (-1 when the label is no COCO class; the caller drops those). Each mask is box-sized:
// sigmoid(coefficients . prototypes), zero outside the box, sampled at the image's pixels and
// thresholded; a detection whose mask holds no pixel is dropped. An error names the layout
// expected when the outputs have another.
Status decodeYoloSeg(const cv::Mat& output0, const cv::Mat& output1, const Letterbox& letterbox,
                     const std::vector<std::string>& labels, const YoloSegDecodeConfig& config,
                     std::vector<Detection2D>* detections);

}  // namespace mvod
