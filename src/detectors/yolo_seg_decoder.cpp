#include "multiview_object_detection/detectors/yolo_seg_decoder.h"

#include <algorithm>
#include <cmath>
#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>

#include "detector_common.h"

namespace mvod {
namespace {

constexpr int kYoloMaskCoefficients = 32;
constexpr int kYoloProtoStride = 4;  // prototypes are S/4 x S/4
// YOLOv5's class offset for class-aware NMS in one pass: boxes of two classes never overlap.
constexpr float kClassOffsetPx = 7680.f;
constexpr unsigned char kLetterboxGrey = 114;

// One candidate row of output0 that passed the score threshold.
struct YoloCandidate {
  int row = 0;
  int label = 0;
  float score = 0.f;
  cv::Rect2d box_input;  // input pixels, unclipped
};

std::vector<YoloCandidate> yoloScoreRows(const float* rows, int num_rows, int stride,
                                         int num_classes, float threshold) {
  std::vector<YoloCandidate> candidates;
  for (int i = 0; i < num_rows; ++i) {
    const float* r = rows + static_cast<size_t>(i) * stride;
    const float objectness = r[4];
    if (!(objectness >= threshold)) continue;  // score <= objectness: no class can pass
    const float* classes = r + 5;
    const int best = static_cast<int>(std::max_element(classes, classes + num_classes) - classes);
    const float score = objectness * classes[best];
    if (!(score >= threshold)) continue;
    if (!(r[2] > 0.f && r[3] > 0.f)) continue;
    candidates.push_back(
        {i, best, score, cv::Rect2d(r[0] - 0.5 * r[2], r[1] - 0.5 * r[3], r[2], r[3])});
  }
  return candidates;
}

// Class-aware NMS (YOLOv5's: each class's boxes shifted apart, one pass), then the highest
// max_detections by score.
std::vector<YoloCandidate> yoloSuppress(const std::vector<YoloCandidate>& candidates,
                                        const YoloSegDecodeConfig& config) {
  std::vector<cv::Rect2d> shifted;
  std::vector<float> scores;
  shifted.reserve(candidates.size());
  scores.reserve(candidates.size());
  for (const YoloCandidate& c : candidates) {
    cv::Rect2d box = c.box_input;
    box.x += c.label * kClassOffsetPx;
    shifted.push_back(box);
    scores.push_back(c.score);
  }
  // NMSBoxes' top_k would cut the candidates before the suppression; YOLOv5 cuts after it.
  std::vector<int> kept;
  cv::dnn::NMSBoxes(shifted, scores, 0.f, config.nms_threshold, kept);
  if (static_cast<int>(kept.size()) > config.max_detections) {
    kept.resize(std::max(0, config.max_detections));
  }
  std::vector<YoloCandidate> result;
  result.reserve(kept.size());
  for (int index : kept) result.push_back(candidates[index]);
  return result;
}

// The instance's mask probabilities on the prototypes' grid over `region` (proto pixels), zero
// outside the box (YOLOv5's crop at prototype resolution: a cell is inside when its index lies in
// [x1, x2) of the box scaled to the grid).
cv::Mat protoMask(const cv::Mat& protos, const float* coefficients, const cv::Rect& region,
                  const cv::Rect2d& box_proto) {
  const int grid = protos.size[2];
  const size_t plane = static_cast<size_t>(grid) * grid;
  const float* p = protos.ptr<float>();
  cv::Mat mask(region.size(), CV_32F, cv::Scalar(0));
  for (int y = region.y; y < region.y + region.height; ++y) {
    if (y < box_proto.y || y >= box_proto.y + box_proto.height) continue;
    float* out = mask.ptr<float>(y - region.y);
    for (int x = region.x; x < region.x + region.width; ++x) {
      if (x < box_proto.x || x >= box_proto.x + box_proto.width) continue;
      const size_t cell = static_cast<size_t>(y) * grid + x;
      float logit = 0.f;
      for (int k = 0; k < kYoloMaskCoefficients; ++k)
        logit += coefficients[k] * p[k * plane + cell];
      out[x - region.x] = 1.f / (1.f + std::exp(-logit));
    }
  }
  return mask;
}

// The box-sized binary mask of one instance: the prototype grid's probabilities resampled
// (bilinearly) at the centres of the box's image pixels, as upsampling the grid to the input and
// resizing the letterboxed part to the image would, then thresholded.
cv::Mat instanceMask(const cv::Mat& protos, const float* coefficients,
                     const YoloCandidate& candidate, const cv::Rect& box_px,
                     const Letterbox& letterbox, float threshold) {
  const int grid = protos.size[2];
  const double proto_per_input = static_cast<double>(grid) / letterbox.input_px;
  // Image pixel u (centre u + 0.5) -> input coordinate -> grid coordinate (cell centres at
  // integers): g = a_x u + b_x.
  const double input_per_image_x =
      static_cast<double>(letterbox.scaled_px.width) / letterbox.image_px.width;
  const double input_per_image_y =
      static_cast<double>(letterbox.scaled_px.height) / letterbox.image_px.height;
  const double a_x = input_per_image_x * proto_per_input;
  const double a_y = input_per_image_y * proto_per_input;
  const double b_x = 0.5 * a_x + letterbox.pad_px.x * proto_per_input - 0.5;
  const double b_y = 0.5 * a_y + letterbox.pad_px.y * proto_per_input - 0.5;
  const cv::Rect2d box_proto(
      candidate.box_input.x * proto_per_input, candidate.box_input.y * proto_per_input,
      candidate.box_input.width * proto_per_input, candidate.box_input.height * proto_per_input);
  // The grid cells the box's pixels sample, with one cell of margin for the interpolation.
  const double gx0 = a_x * box_px.x + b_x;
  const double gy0 = a_y * box_px.y + b_y;
  const double gx1 = a_x * (box_px.x + box_px.width - 1) + b_x;
  const double gy1 = a_y * (box_px.y + box_px.height - 1) + b_y;
  const cv::Rect region =
      cv::Rect(
          cv::Point(static_cast<int>(std::floor(gx0)) - 1, static_cast<int>(std::floor(gy0)) - 1),
          cv::Point(static_cast<int>(std::ceil(gx1)) + 2, static_cast<int>(std::ceil(gy1)) + 2)) &
      cv::Rect(0, 0, grid, grid);
  if (region.empty()) return cv::Mat::zeros(box_px.size(), CV_8UC1);
  const cv::Mat probabilities = protoMask(protos, coefficients, region, box_proto);
  // dst (j, i) of the box -> src (a_x (box.x + j) + b_x - region.x, ...).
  const cv::Matx23d dst_to_src(a_x, 0.0, a_x * box_px.x + b_x - region.x, 0.0, a_y,
                               a_y * box_px.y + b_y - region.y);
  cv::Mat sampled;
  cv::warpAffine(probabilities, sampled, dst_to_src, box_px.size(),
                 cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REPLICATE);
  cv::Mat mask = cv::Mat::zeros(box_px.size(), CV_8UC1);
  mask.setTo(255, sampled > threshold);
  return mask;
}

Status checkYoloLayout(const cv::Mat& output0, const cv::Mat& output1, const Letterbox& letterbox,
                       const std::vector<std::string>& labels) {
  const int s = letterbox.input_px;
  const std::string expected =
      "YOLOv5-seg outputs must be output0 [1, N, 5 + classes + 32] and output1 [1, 32, S/4, S/4] "
      "float blobs (S = " +
      std::to_string(s) + ", N = " + std::to_string(yoloSegRows(s)) + ")";
  if (output0.dims != 3 || output0.size[0] != 1 || output0.type() != CV_32F ||
      output0.size[2] <= 5 + kYoloMaskCoefficients || output1.dims != 4 || output1.size[0] != 1 ||
      output1.type() != CV_32F || output1.size[1] != kYoloMaskCoefficients ||
      output1.size[2] != s / kYoloProtoStride || output1.size[3] != s / kYoloProtoStride) {
    return Status::Error(expected);
  }
  const int num_classes = output0.size[2] - 5 - kYoloMaskCoefficients;
  if (static_cast<int>(labels.size()) < num_classes) {
    return Status::Error("YOLOv5-seg gives " + std::to_string(num_classes) +
                         " classes but the label file has " + std::to_string(labels.size()) +
                         " names");
  }
  return Status::Ok();
}

}  // namespace

int yoloSegRows(int input_px) {
  int rows = 0;
  for (int stride : {8, 16, 32}) rows += 3 * (input_px / stride) * (input_px / stride);
  return rows;
}

Letterbox Letterbox::fit(const cv::Size& image_size, int input_px) {
  Letterbox letterbox;
  letterbox.input_px = input_px;
  letterbox.image_px = image_size;
  letterbox.scale = std::min(static_cast<double>(input_px) / image_size.width,
                             static_cast<double>(input_px) / image_size.height);
  letterbox.scaled_px =
      cv::Size(static_cast<int>(std::lround(image_size.width * letterbox.scale)),
               static_cast<int>(std::lround(image_size.height * letterbox.scale)));
  // YOLOv5: the padding split in two, the odd pixel to the right and bottom.
  letterbox.pad_px =
      cv::Point(static_cast<int>(std::lround((input_px - letterbox.scaled_px.width) / 2.0 - 0.1)),
                static_cast<int>(std::lround((input_px - letterbox.scaled_px.height) / 2.0 - 0.1)));
  return letterbox;
}

cv::Mat Letterbox::blob(const cv::Mat& image_bgr) const {
  cv::Mat input(input_px, input_px, CV_8UC3, cv::Scalar::all(kLetterboxGrey));
  cv::Mat scaled;
  if (scaled_px == image_bgr.size()) {
    scaled = image_bgr;
  } else {
    cv::resize(image_bgr, scaled, scaled_px, 0, 0, cv::INTER_LINEAR);
  }
  scaled.copyTo(input(cv::Rect(pad_px, scaled_px)));
  return cv::dnn::blobFromImage(input, 1.0 / 255.0, input.size(), cv::Scalar(), true, false);
}

Status decodeYoloSeg(const cv::Mat& output0, const cv::Mat& output1, const Letterbox& letterbox,
                     const std::vector<std::string>& labels, const YoloSegDecodeConfig& config,
                     std::vector<Detection2D>* detections) {
  detections->clear();
  const Status layout = checkYoloLayout(output0, output1, letterbox, labels);
  if (!layout) return layout;
  if (letterbox.image_px.width <= 0 || letterbox.image_px.height <= 0) {
    return Status::Error("YOLOv5-seg: empty image size");
  }
  const cv::Mat rows_blob = output0.isContinuous() ? output0 : output0.clone();
  const cv::Mat protos = output1.isContinuous() ? output1 : output1.clone();
  const int stride = output0.size[2];
  const int num_classes = stride - 5 - kYoloMaskCoefficients;
  const float* rows = rows_blob.ptr<float>();
  const std::vector<YoloCandidate> kept = yoloSuppress(
      yoloScoreRows(rows, output0.size[1], stride, num_classes, config.score_threshold), config);
  for (const YoloCandidate& candidate : kept) {
    const cv::Rect2d& b = candidate.box_input;
    Detection2D detection;
    detection.box_px = detector_common::clippedBox(
        (b.x - letterbox.pad_px.x) / letterbox.scale, (b.y - letterbox.pad_px.y) / letterbox.scale,
        (b.x + b.width - letterbox.pad_px.x) / letterbox.scale,
        (b.y + b.height - letterbox.pad_px.y) / letterbox.scale, letterbox.image_px);
    if (detection.box_px.area() <= 0) continue;
    const float* coefficients =
        rows + static_cast<size_t>(candidate.row) * stride + 5 + num_classes;
    detection.mask = instanceMask(protos, coefficients, candidate, detection.box_px, letterbox,
                                  config.mask_threshold);
    if (cv::countNonZero(detection.mask) == 0) continue;
    detection.mask_cell_px = static_cast<float>(kYoloProtoStride / letterbox.scale);
    detector_common::setClass(labels[candidate.label], &detection);
    detection.score = candidate.score;
    detections->push_back(std::move(detection));
  }
  return Status::Ok();
}

}  // namespace mvod
