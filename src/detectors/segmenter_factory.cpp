#include "multiview_object_detection/detectors/segmenter_factory.h"

#include <sys/stat.h>

#include <cstdio>
#include <cstdlib>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/detectors/dnn_instance_segmenter.h"
#include "multiview_object_detection/detectors/file_instance_segmenter.h"
#include "multiview_object_detection/pipeline/utils/label_layout.h"

namespace mvod {
namespace {

// yolo_seg's score threshold and λ (detectorThresholds).
constexpr float kYoloSegScoreThreshold = 0.15f;

}  // namespace

DetectorThresholds detectorThresholds(const std::string& detector) {
  // score, NMS IoU, mask, λ. fastestdet and maskrcnn: the values these detectors have had since
  // the start (FastestDet upstream uses 0.65-0.8). yolo_seg, measured on the redkitchen
  // (benchmark/redkitchen_benchmark, docs/parameters.md "Detector thresholds"): a score and λ of
  // 0.5 leave the map without the table; a mask threshold of 0.3 keeps 3 of 5 chairs where
  // YOLOv5's own 0.5 keeps 1 (its thinner masks lose the slats). NMS: YOLOv5's 0.45.
  if (detector == "yolo_seg") return {kYoloSegScoreThreshold, 0.45f, 0.3f, kYoloSegScoreThreshold};
  if (detector == "fastestdet") return {0.5f, 0.4f, 0.5f, 0.5};
  if (detector == "maskrcnn") return {0.5f, 0.4f, 0.3f, 0.5};
  return {0.5f, 0.4f, 0.5f, 0.5};
}

SegmenterOptions SegmenterOptions::withDetectorDefaults() const {
  SegmenterOptions resolved = *this;
  const DetectorThresholds defaults = detectorThresholds(detector);
  if (resolved.score_threshold == kDetectorDefault) {
    resolved.score_threshold = defaults.score_threshold;
  }
  if (resolved.nms_threshold == kDetectorDefault) resolved.nms_threshold = defaults.nms_threshold;
  if (resolved.mask_threshold == kDetectorDefault) {
    resolved.mask_threshold = defaults.mask_threshold;
  }
  return resolved;
}

Status SegmenterOptions::isValid() const {
  if (detector == "simulated") {
    return Status::Error(
        "detector 'simulated' is the benchmark's ground-truth detector: offline_detection, "
        "dataset_to_bag and ablation offer it, the node does not (use files, yolo_seg, "
        "fastestdet, maskrcnn)");
  }
  if (detector != "files" && detector != "yolo_seg" && detector != "fastestdet" &&
      detector != "maskrcnn") {
    return Status::Error("detector '" + detector +
                         "' is unknown (use files, yolo_seg, fastestdet or maskrcnn)");
  }
  if (detector == "files" && detections_dir.empty()) {
    return Status::Error("detector 'files' needs a detections folder");
  }
  return isValidExceptDetector();
}

Status SegmenterOptions::isValidExceptDetector() const {
  const auto own = [](float value) { return value == kDetectorDefault; };
  if (!own(score_threshold) && !(score_threshold >= 0.f && score_threshold <= 1.f)) {
    return Status::Error("score_threshold must be in [0, 1] (or unset: the detector's own)");
  }
  if (!own(nms_threshold) && !(nms_threshold > 0.f && nms_threshold <= 1.f)) {
    return Status::Error("nms_threshold must be in (0, 1] (or unset: the detector's own)");
  }
  if (!own(mask_threshold) && !(mask_threshold > 0.f && mask_threshold < 1.f)) {
    return Status::Error("mask_threshold must be in (0, 1) (or unset: the detector's own)");
  }
  if (max_detections < 1) return Status::Error("max_detections must be >= 1");
  if (yolo_seg_input_px != 0 &&
      (yolo_seg_input_px < 32 || yolo_seg_input_px % 32 != 0 || yolo_seg_input_px > 4096)) {
    return Status::Error(
        "yolo_seg input size must be 0 (the file's) or a multiple of 32 up to "
        "4096");
  }
  if (backend != "cpu" && backend != "cuda") {
    return Status::Error("backend '" + backend + "' is unknown (use cpu or cuda)");
  }
  return Status::Ok();
}

std::string resolveAutoDetector(const SegmenterOptions& options) {
  if (options.detector != "auto") return options.detector;
  struct stat info;
  const std::string yolo = resolveModelPath(options, options.yolo_seg_model);
  if (::stat(yolo.c_str(), &info) == 0 && S_ISREG(info.st_mode)) return "yolo_seg";
  return "fastestdet";
}

std::string defaultModelDirectory() {
  const char* ros_home = std::getenv("ROS_HOME");
  const char* home = std::getenv("HOME");
  std::string base;
  if (ros_home != nullptr && *ros_home != '\0') {
    base = ros_home;
  } else if (home != nullptr && *home != '\0') {
    base = std::string(home) + "/.ros";
  } else {
    return "";
  }
  return base + "/multiview_object_detection/models";
}

std::string modelDirectory(const SegmenterOptions& options) {
  if (!options.model_dir.empty()) return options.model_dir;
  const char* env = std::getenv("MVOD_MODEL_DIR");
  if (env != nullptr && *env != '\0') return env;
  return defaultModelDirectory();
}

std::string resolveModelPath(const SegmenterOptions& options, const std::string& file) {
  if (file.empty() || file.front() == '/') return file;
  const std::string dir = modelDirectory(options);
  if (dir.empty()) return file;
  return dir + "/" + file;
}

Status createInstanceSegmenter(const SegmenterOptions& given,
                               std::unique_ptr<InstanceSegmenter>* segmenter) {
  segmenter->reset();
  const Status valid = given.isValid();
  if (!valid) return valid;
  const SegmenterOptions options = given.withDetectorDefaults();
  if (options.detector == "files") {
    FileInstanceSegmenter::Config config;
    config.max_detections = options.max_detections;
    *segmenter = std::make_unique<FileInstanceSegmenter>(options.detections_dir, config);
    return Status::Ok();
  }
  DnnModelOptions dnn;
  dnn.backend = options.backend;
  dnn.decode.score_threshold = options.score_threshold;
  dnn.decode.nms_threshold = options.nms_threshold;
  dnn.decode.mask_threshold = options.mask_threshold;
  DnnInstanceSegmenter::Model model = DnnInstanceSegmenter::Model::kFastestDet;
  if (options.detector == "fastestdet") {
    dnn.model_path = resolveModelPath(options, options.fastestdet_model);
    dnn.labels_path = resolveModelPath(options, options.fastestdet_labels);
  } else if (options.detector == "yolo_seg") {
    model = DnnInstanceSegmenter::Model::kYoloSeg;
    dnn.model_path = resolveModelPath(options, options.yolo_seg_model);
    dnn.labels_path = resolveModelPath(options, options.yolo_seg_labels);
    dnn.input_px = options.yolo_seg_input_px;
  } else {
    model = DnnInstanceSegmenter::Model::kMaskRcnn;
    dnn.model_path = resolveModelPath(options, options.maskrcnn_weights);
    dnn.config_path = resolveModelPath(options, options.maskrcnn_graph);
    dnn.labels_path = resolveModelPath(options, options.maskrcnn_labels);
  }
  std::unique_ptr<DnnInstanceSegmenter> dnn_segmenter;
  const Status created = DnnInstanceSegmenter::create(model, dnn, &dnn_segmenter);
  if (!created) return created;
  *segmenter = std::move(dnn_segmenter);
  return Status::Ok();
}

DetectionLabels layoutDetectionLabels(const std::vector<Detection2D>& detections,
                                      const cv::Size& image_size) {
  // "class score" over each box's top-left corner, at the free spot nearest it: boxes that share
  // a top edge would otherwise cover each other's labels.
  DetectionLabels labels;
  std::vector<cv::Point> anchors;
  std::vector<cv::Size> sizes;
  for (const Detection2D& det : detections) {
    char text[160];
    std::snprintf(text, sizeof(text), "%s %.2f", det.class_name.c_str(), det.score);
    const cv::Size size = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, 0.5, 1, &labels.baseline);
    labels.texts.emplace_back(text);
    sizes.emplace_back(size.width, size.height + labels.baseline + 2);
    anchors.emplace_back(det.box_px.x + size.width / 2, det.box_px.y - 2 - sizes.back().height / 2);
  }
  labels.spots = layoutLabels(anchors, sizes, cv::Rect(cv::Point(), image_size), {2, 80, 0});
  return labels;
}

cv::Mat drawDetections(const cv::Mat& image_bgr, const std::vector<Detection2D>& detections) {
  return drawDetections(image_bgr, detections, layoutDetectionLabels(detections, image_bgr.size()));
}

cv::Mat drawDetections(const cv::Mat& image_bgr, const std::vector<Detection2D>& detections,
                       const DetectionLabels& labels) {
  cv::Mat canvas = image_bgr.clone();
  std::vector<cv::Scalar> colours;
  for (size_t i = 0; i < detections.size(); ++i) {
    const Detection2D& det = detections[i];
    // A colour per class, stable between frames.
    const int h = (det.class_id >= 0 ? det.class_id * 37 : static_cast<int>(i) * 53) % 180;
    cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(h, 200, 255));
    cv::Mat bgr;
    cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
    const cv::Vec3b c = bgr.at<cv::Vec3b>(0, 0);
    colours.emplace_back(c[0], c[1], c[2]);
    // Box-sized masks (the DNN detectors') and image-sized ones (files) alike.
    cv::Point mask_origin;
    if (maskOrigin(det, canvas.size(), &mask_origin)) {
      const cv::Rect region =
          cv::Rect(mask_origin, det.mask.size()) & cv::Rect(cv::Point(), canvas.size());
      cv::Mat tint(region.size(), CV_8UC3, colours.back());
      cv::Mat blended;
      cv::addWeighted(canvas(region), 0.55, tint, 0.45, 0.0, blended);
      blended.copyTo(canvas(region), maskInRegion(det, canvas.size(), region));
    }
    cv::rectangle(canvas, det.box_px, colours.back(), 2);
  }
  for (size_t i = 0; i < labels.spots.size() && i < colours.size(); ++i) {
    const cv::Rect& spot = labels.spots[i];
    cv::rectangle(canvas, spot, colours[i], cv::FILLED);
    const cv::Point origin(spot.x, spot.y + spot.height - labels.baseline);
    cv::putText(canvas, labels.texts[i], origin, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0),
                1);
  }
  return canvas;
}

}  // namespace mvod
