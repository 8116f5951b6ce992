#include "multiview_object_detection/detectors/segmenter_factory.h"

#include <cstdlib>
#include <opencv2/imgproc.hpp>

#include "multiview_object_detection/detectors/dnn_instance_segmenter.h"
#include "multiview_object_detection/detectors/file_instance_segmenter.h"

namespace mvod {

Status SegmenterOptions::isValid() const {
  if (detector == "simulated") {
    return Status::Error(
        "detector 'simulated' is the benchmark's ground-truth detector: offline_detection, "
        "dataset_to_bag and ablation offer it, the node does not (use files, fastestdet, "
        "maskrcnn)");
  }
  if (detector != "files" && detector != "fastestdet" && detector != "maskrcnn") {
    return Status::Error("detector '" + detector +
                         "' is unknown (use files, fastestdet or maskrcnn)");
  }
  if (detector == "files" && detections_dir.empty()) {
    return Status::Error("detector 'files' needs a detections folder");
  }
  return isValidExceptDetector();
}

Status SegmenterOptions::isValidExceptDetector() const {
  if (!(score_threshold >= 0.f && score_threshold <= 1.f)) {
    return Status::Error("score_threshold must be in [0, 1]");
  }
  if (!(nms_threshold > 0.f && nms_threshold <= 1.f)) {
    return Status::Error("nms_threshold must be in (0, 1]");
  }
  if (!(mask_threshold > 0.f && mask_threshold < 1.f)) {
    return Status::Error("mask_threshold must be in (0, 1)");
  }
  if (max_detections < 1) return Status::Error("max_detections must be >= 1");
  if (backend != "cpu" && backend != "cuda") {
    return Status::Error("backend '" + backend + "' is unknown (use cpu or cuda)");
  }
  return Status::Ok();
}

std::string resolveModelPath(const SegmenterOptions& options, const std::string& file) {
  if (file.empty() || file.front() == '/') return file;
  std::string dir = options.model_dir;
  if (dir.empty()) {
    const char* env = std::getenv("MVOD_MODEL_DIR");
    if (env != nullptr) dir = env;
  }
  if (dir.empty()) return file;
  return dir + "/" + file;
}

Status createInstanceSegmenter(const SegmenterOptions& options,
                               std::unique_ptr<InstanceSegmenter>* segmenter) {
  segmenter->reset();
  const Status valid = options.isValid();
  if (!valid) return valid;
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

cv::Mat drawDetections(const cv::Mat& image_bgr, const std::vector<Detection2D>& detections) {
  cv::Mat canvas = image_bgr.clone();
  for (size_t i = 0; i < detections.size(); ++i) {
    const Detection2D& det = detections[i];
    // A colour per class, stable between frames.
    const int h = (det.class_id >= 0 ? det.class_id * 37 : static_cast<int>(i) * 53) % 180;
    cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(h, 200, 255));
    cv::Mat bgr;
    cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
    const cv::Vec3b c = bgr.at<cv::Vec3b>(0, 0);
    const cv::Scalar colour(c[0], c[1], c[2]);
    if (!det.mask.empty() && det.mask.size() == canvas.size() && det.mask.type() == CV_8UC1) {
      cv::Mat tint(canvas.size(), CV_8UC3, colour);
      cv::Mat blended;
      cv::addWeighted(canvas, 0.55, tint, 0.45, 0.0, blended);
      blended.copyTo(canvas, det.mask);
    }
    cv::rectangle(canvas, det.box_px, colour, 2);
    char text[128];
    std::snprintf(text, sizeof(text), "%s %.2f", det.class_name.c_str(), det.score);
    int baseline = 0;
    const cv::Size size = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, 0.5, 1, &baseline);
    const cv::Point origin(det.box_px.x, std::max(size.height + 2, det.box_px.y - 2));
    cv::rectangle(canvas, origin + cv::Point(0, baseline),
                  origin + cv::Point(size.width, -size.height - 2), colour, cv::FILLED);
    cv::putText(canvas, text, origin, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1);
  }
  return canvas;
}

}  // namespace mvod
