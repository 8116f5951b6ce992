#include "multiview_object_detection/detectors/dnn_instance_segmenter.h"

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "detector_common.h"
#include "multiview_object_detection/detectors/onnx_input_shape.h"
#include "multiview_object_detection/detectors/yolo_seg_decoder.h"
#include "multiview_object_detection/io/file_io.h"
#include "multiview_object_detection/pipeline/types/class_priors.h"

namespace mvod {
namespace {

using detector_common::clippedBox;
using detector_common::setClass;

constexpr int kFastestDetInputPx = 352;
// YOLOv5-seg: the input side of a dynamic export (the official default), and its strides' largest.
constexpr int kYoloSegDefaultInputPx = 640;
constexpr int kYoloSegStridePx = 32;
// The blank image of Mask R-CNN's forward pass at load time (the graph resizes it internally).
constexpr int kMaskRcnnProbePx = 64;

float sigmoid(float x) { return 1.f / (1.f + std::exp(-x)); }

bool isReadableFile(const std::string& path, long* size_bytes) {
  struct stat info;
  if (::stat(path.c_str(), &info) != 0 || !S_ISREG(info.st_mode)) return false;
  *size_bytes = static_cast<long>(info.st_size);
  return std::ifstream(path).good();
}

// Per-class non-maximum suppression; keeps the input order of the survivors by score.
std::vector<Detection2D> suppressNonMaxima(std::vector<Detection2D> candidates, float nms_iou) {
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Detection2D& a, const Detection2D& b) { return a.score > b.score; });
  std::vector<Detection2D> kept;
  for (Detection2D& candidate : candidates) {
    bool suppressed = false;
    for (const Detection2D& k : kept) {
      if (k.class_id != candidate.class_id) continue;
      const double inter = (k.box_px & candidate.box_px).area();
      const double uni = k.box_px.area() + candidate.box_px.area() - inter;
      if (uni > 0.0 && inter / uni > nms_iou) {
        suppressed = true;
        break;
      }
    }
    if (!suppressed) kept.push_back(std::move(candidate));
  }
  return kept;
}

std::string missingModelHelp(const std::string& what) {
  return what +
         ". Model files are looked up by name in the model folder (the model_dir parameter, the "
         "--model-dir option or $MVOD_MODEL_DIR); scripts/download_models.sh fetches them and "
         "checks "
         "their sha256 (README, 'Models and data').";
}

// The Mask R-CNN outputs decodeMaskRcnn reads.
std::vector<std::string> maskRcnnOutputs() { return {"detection_out_final", "detection_masks"}; }
// The YOLOv5-seg outputs decodeYoloSeg reads (the official export's names).
std::vector<std::string> yoloSegOutputs() { return {"output0", "output1"}; }

YoloSegDecodeConfig yoloSegConfig(const DnnDecodeConfig& decode) {
  YoloSegDecodeConfig config;
  config.score_threshold = decode.score_threshold;
  config.nms_threshold = decode.nms_threshold;
  config.mask_threshold = decode.mask_threshold;
  return config;
}

const char* const kYoloSegLayout =
    "the official YOLOv5-seg export (ultralytics/yolov5 v7.0 `export.py --include onnx`): input "
    "'images' [1, 3, S, S], outputs 'output0' [1, N, 5 + 80 + 32] and 'output1' [1, 32, S/4, S/4]";

// The input side S of a YOLOv5-seg ONNX file: its declared input, or `requested` (0: 640) where it
// declares none. An error names the layout expected.
Status yoloSegInputPx(const std::string& path, int requested, int* input_px) {
  std::vector<OnnxInput> inputs;
  const Status read = readOnnxInputs(path, &inputs);
  if (!read) return Status::Error(read.message() + "; expected " + kYoloSegLayout);
  const auto images = std::find_if(inputs.begin(), inputs.end(),
                                   [](const OnnxInput& input) { return input.name == "images"; });
  if (images == inputs.end() || images->dims.size() != 4 ||
      (images->dims[1] != 3 && images->dims[1] != -1)) {
    std::string found;
    for (const OnnxInput& input : inputs) found += (found.empty() ? "'" : ", '") + input.name + "'";
    return Status::Error("'" + path + "' has inputs " + (found.empty() ? "none" : found) +
                         ", not " + kYoloSegLayout);
  }
  const int64_t declared_h = images->dims[2];
  const int64_t declared_w = images->dims[3];
  if (declared_h != declared_w) {
    return Status::Error("'" + path + "' declares a non-square input; expected " + kYoloSegLayout);
  }
  if (declared_h > 0 && requested > 0 && declared_h != requested) {
    return Status::Error("'" + path + "' was exported for " + std::to_string(declared_h) + " x " +
                         std::to_string(declared_h) + " input, not the " +
                         std::to_string(requested) + " asked for (export it again at that size)");
  }
  const int64_t side =
      declared_h > 0 ? declared_h : (requested > 0 ? requested : kYoloSegDefaultInputPx);
  if (side % kYoloSegStridePx != 0 || side > 4096) {
    return Status::Error("'" + path + "': input side " + std::to_string(side) +
                         " is not a multiple of 32 up to 4096");
  }
  *input_px = static_cast<int>(side);
  return Status::Ok();
}

// The number of classes the network scores, from a forward pass on a blank image (the ONNX and
// TensorFlow importers know the output shapes only after one): FastestDet's output has 5 + classes
// channels, Mask R-CNN's detection_masks one mask per class.
Status networkClassCount(DnnInstanceSegmenter::Model model, int input_px, cv::dnn::Net* net,
                         int* classes) {
  try {
    if (model == DnnInstanceSegmenter::Model::kYoloSeg) {
      const Letterbox letterbox = Letterbox::fit(cv::Size(input_px, input_px), input_px);
      net->setInput(letterbox.blob(cv::Mat(input_px, input_px, CV_8UC3, cv::Scalar::all(0))));
      std::vector<cv::Mat> outputs;
      net->forward(outputs, yoloSegOutputs());
      std::vector<Detection2D> none;
      const std::vector<std::string> any_labels(outputs[0].dims == 3 ? outputs[0].size[2] : 0);
      const Status layout = decodeYoloSeg(outputs[0], outputs[1], letterbox, any_labels,
                                          YoloSegDecodeConfig(), &none);
      if (!layout) return Status::Error(layout.message() + "; expected " + kYoloSegLayout);
      *classes = outputs[0].size[2] - 5 - 32;
    } else if (model == DnnInstanceSegmenter::Model::kFastestDet) {
      const cv::Mat blank(kFastestDetInputPx, kFastestDetInputPx, CV_8UC3, cv::Scalar::all(0));
      net->setInput(
          cv::dnn::blobFromImage(blank, 1.0 / 255.0, blank.size(), cv::Scalar(), false, false));
      const cv::Mat output = net->forward();
      if (output.dims != 4 || output.size[1] < 6) {
        return Status::Error("its output is not a [1, 5 + classes, H, W] blob");
      }
      *classes = output.size[1] - 5;
    } else {
      const cv::Mat blank(kMaskRcnnProbePx, kMaskRcnnProbePx, CV_8UC3, cv::Scalar::all(0));
      net->setInput(cv::dnn::blobFromImage(blank, 1.0, blank.size(), cv::Scalar(), true, false));
      std::vector<cv::Mat> outputs;
      net->forward(outputs, maskRcnnOutputs());
      if (outputs.size() != 2 || outputs[1].dims != 4) {
        return Status::Error("its detection_masks output is not an [N, classes, h, w] blob");
      }
      *classes = outputs[1].size[1];
    }
  } catch (const cv::Exception& e) {
    return Status::Error(std::string("a forward pass on a blank image failed (") +
                         (model == DnnInstanceSegmenter::Model::kYoloSeg
                              ? std::string("expected ") + kYoloSegLayout + "): "
                              : "): ") +
                         e.what());
  }
  return Status::Ok();
}

}  // namespace

Status readLabelFile(const std::string& path, std::vector<std::string>* labels) {
  // A FIFO or device at the path is refused at once; a label file is a few kB (80 names).
  constexpr size_t kMaxLabelFileBytes = size_t{1} << 20;
  std::string text;
  const Status read = readFile(path, &text, kMaxLabelFileBytes);
  if (!read) return Status::Error("label file: " + read.message());
  std::istringstream in(text);
  std::vector<std::string> names;
  std::string line;
  while (std::getline(in, line)) {
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
    names.push_back(line);
  }
  while (!names.empty() && names.back().empty()) names.pop_back();
  if (names.empty()) return Status::Error("label file " + path + " holds no names");
  *labels = std::move(names);
  return Status::Ok();
}

Status decodeFastestDet(const cv::Mat& output, const cv::Size& image_size,
                        const std::vector<std::string>& labels, const DnnDecodeConfig& config,
                        std::vector<Detection2D>* detections) {
  detections->clear();
  if (output.dims != 4 || output.size[0] != 1 || output.type() != CV_32F || output.size[1] < 6) {
    return Status::Error("FastestDet output must be a [1, 5 + classes, H, W] float blob");
  }
  const int channels = output.size[1];
  const int grid_h = output.size[2];
  const int grid_w = output.size[3];
  const int num_classes = channels - 5;
  if (grid_h < 1 || grid_w < 1) return Status::Error("FastestDet output has an empty grid");
  if (static_cast<int>(labels.size()) < num_classes) {
    return Status::Error("FastestDet gives " + std::to_string(num_classes) + " classes but the " +
                         "label file has " + std::to_string(labels.size()) + " names");
  }
  if (image_size.width <= 0 || image_size.height <= 0) {
    return Status::Error("FastestDet: empty image size");
  }
  const cv::Mat blob = output.isContinuous() ? output : output.clone();
  const float* data = blob.ptr<float>();
  const size_t plane = static_cast<size_t>(grid_h) * grid_w;
  auto at = [&](int c, int h, int w) {
    return data[c * plane + static_cast<size_t>(h) * grid_w + w];
  };

  std::vector<Detection2D> candidates;
  for (int h = 0; h < grid_h; ++h) {
    for (int w = 0; w < grid_w; ++w) {
      const float objectness = at(0, h, w);
      int best_class = 0;
      float best_score = at(5, h, w);
      for (int c = 1; c < num_classes; ++c) {
        const float s = at(5 + c, h, w);
        if (s > best_score) {
          best_score = s;
          best_class = c;
        }
      }
      const float score = objectness * best_score;
      if (!(score >= config.score_threshold)) continue;
      const double cx = (w + std::tanh(at(1, h, w))) / grid_w * image_size.width;
      const double cy = (h + std::tanh(at(2, h, w))) / grid_h * image_size.height;
      const double bw = sigmoid(at(3, h, w)) * image_size.width;
      const double bh = sigmoid(at(4, h, w)) * image_size.height;
      Detection2D detection;
      detection.box_px =
          clippedBox(cx - 0.5 * bw, cy - 0.5 * bh, cx + 0.5 * bw, cy + 0.5 * bh, image_size);
      if (detection.box_px.area() <= 0) continue;
      setClass(labels[best_class], &detection);
      detection.score = score;
      candidates.push_back(std::move(detection));
    }
  }
  *detections = suppressNonMaxima(std::move(candidates), config.nms_threshold);
  for (Detection2D& detection : *detections) {
    detection.mask = cv::Mat(detection.box_px.size(), CV_8UC1, cv::Scalar(255));  // box-sized
  }
  return Status::Ok();
}

Status decodeMaskRcnn(const cv::Mat& detection_out, const cv::Mat& detection_masks,
                      const cv::Size& image_size, const std::vector<std::string>& labels,
                      const DnnDecodeConfig& config, std::vector<Detection2D>* detections) {
  detections->clear();
  if (detection_out.dims != 4 || detection_out.size[3] != 7 || detection_out.type() != CV_32F) {
    return Status::Error("Mask R-CNN detection_out_final must be a [1, 1, N, 7] float blob");
  }
  const int num = detection_out.size[2];
  if (num == 0) return Status::Ok();
  if (detection_masks.dims != 4 || detection_masks.type() != CV_32F ||
      detection_masks.size[0] < num) {
    return Status::Error(
        "Mask R-CNN detection_masks must be a [N, classes, h, w] float blob with "
        "at least as many masks as detections (" +
        std::to_string(num) + ")");
  }
  if (image_size.width <= 0 || image_size.height <= 0) {
    return Status::Error("Mask R-CNN: empty image size");
  }
  const int mask_classes = detection_masks.size[1];
  const int mask_h = detection_masks.size[2];
  const int mask_w = detection_masks.size[3];
  const cv::Mat out = detection_out.isContinuous() ? detection_out : detection_out.clone();
  const cv::Mat masks = detection_masks.isContinuous() ? detection_masks : detection_masks.clone();
  const float* rows = out.ptr<float>();
  std::vector<Detection2D> candidates;
  for (int i = 0; i < num; ++i) {
    const float* r = rows + 7 * i;
    const float score = r[2];
    if (!(score >= config.score_threshold)) continue;
    const int class_index = static_cast<int>(std::lround(r[1]));
    if (class_index < 0 || class_index >= mask_classes) continue;
    Detection2D detection;
    detection.score = score;
    setClass(class_index < static_cast<int>(labels.size()) ? labels[class_index] : std::string(),
             &detection);
    detection.box_px = clippedBox(r[3] * image_size.width, r[4] * image_size.height,
                                  r[5] * image_size.width, r[6] * image_size.height, image_size);
    if (detection.box_px.area() <= 0) continue;
    // The class's low-resolution mask, stretched over the box (OpenCV's mask_rcnn sample does the
    // same), thresholded into the box-sized binary mask.
    const cv::Mat small(
        mask_h, mask_w, CV_32F,
        const_cast<float*>(masks.ptr<float>()) +
            (static_cast<size_t>(i) * mask_classes + class_index) * mask_h * mask_w);
    cv::Mat stretched;
    cv::resize(small, stretched, detection.box_px.size(), 0, 0, cv::INTER_LINEAR);
    detection.mask = cv::Mat::zeros(detection.box_px.size(), CV_8UC1);
    detection.mask.setTo(255, stretched > config.mask_threshold);
    detection.mask_cell_px =
        static_cast<float>(std::max(static_cast<double>(detection.box_px.width) / mask_w,
                                    static_cast<double>(detection.box_px.height) / mask_h));
    candidates.push_back(std::move(detection));
  }
  // The network already applies NMS; this only removes exact repeats the graph may emit.
  *detections = suppressNonMaxima(std::move(candidates), std::max(config.nms_threshold, 0.9f));
  return Status::Ok();
}

struct DnnInstanceSegmenter::Network {
  cv::dnn::Net net;
};

DnnInstanceSegmenter::DnnInstanceSegmenter(Model model, const DnnModelOptions& options)
    : model_(model), options_(options), network_(std::make_unique<Network>()) {}

DnnInstanceSegmenter::~DnnInstanceSegmenter() = default;

std::string DnnInstanceSegmenter::name() const {
  switch (model_) {
    case Model::kFastestDet:
      return "fastestdet";
    case Model::kYoloSeg:
      return "yolo_seg";
    case Model::kMaskRcnn:
      break;
  }
  return "maskrcnn";
}

Status DnnInstanceSegmenter::create(Model model, const DnnModelOptions& options,
                                    std::unique_ptr<DnnInstanceSegmenter>* segmenter) {
  segmenter->reset();
  const std::string model_name = model == Model::kFastestDet ? "FastestDet"
                                 : model == Model::kYoloSeg  ? "YOLOv5-seg"
                                                             : "Mask R-CNN";
  long size_bytes = 0;
  if (!isReadableFile(options.model_path, &size_bytes)) {
    const std::string how =
        model == Model::kYoloSeg
            ? "; or export it yourself from the v7.0 release weights with `python export.py "
              "--weights yolov5n-seg.pt --include onnx --opset 12` in ultralytics/yolov5 "
              "(--imgsz 320 for the faster 320 export; yolov5s/m-seg the same way)"
            : "";
    return Status::Error(
        missingModelHelp(model_name + " weights not found: '" + options.model_path + "'") + how);
  }
  if (model == Model::kMaskRcnn && !isReadableFile(options.config_path, &size_bytes)) {
    return Status::Error(
        missingModelHelp("Mask R-CNN text graph not found: '" + options.config_path + "'"));
  }
  std::unique_ptr<DnnInstanceSegmenter> result(new DnnInstanceSegmenter(model, options));
  if (model == Model::kYoloSeg) {
    const Status sized = yoloSegInputPx(options.model_path, options.input_px, &result->input_px_);
    if (!sized) return Status::Error(model_name + ": " + sized.message());
  }
  Status labels_read = readLabelFile(options.labels_path, &result->labels_);
  if (!labels_read) {
    // The class names are part of the model: without the file use the built-in COCO list of the
    // same length when there is one.
    if (model != Model::kMaskRcnn) {
      result->labels_ = cocoClassNames();
    } else {
      return Status::Error(missingModelHelp(labels_read.message()));
    }
  }
  try {
    if (model != Model::kMaskRcnn) {
      result->network_->net = cv::dnn::readNetFromONNX(options.model_path);
    } else {
      result->network_->net =
          cv::dnn::readNetFromTensorflow(options.model_path, options.config_path);
    }
  } catch (const cv::Exception& e) {
    return Status::Error(missingModelHelp(model_name + " model '" + options.model_path +
                                          "' could not be loaded (corrupt or not the expected " +
                                          "model?): " + e.what()));
  }
  if (result->network_->net.empty()) {
    return Status::Error(missingModelHelp(model_name + " model '" + options.model_path +
                                          "' loaded as an empty network"));
  }
  if (options.backend == "cuda") {
    result->network_->net.setPreferableBackend(cv::dnn::DNN_BACKEND_CUDA);
    result->network_->net.setPreferableTarget(cv::dnn::DNN_TARGET_CUDA);
  } else {
    result->network_->net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
    result->network_->net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  }
  // The label file must name every class the network scores, no more: a file of another model
  // would fail every keyframe (too few names) or misname every detection.
  int classes = 0;
  const Status counted =
      networkClassCount(model, result->input_px_, &result->network_->net, &classes);
  if (!counted) {
    return Status::Error(model_name + " model '" + options.model_path + "': " + counted.message());
  }
  if (static_cast<int>(result->labels_.size()) != classes) {
    const std::string label_source =
        labels_read ? "label file '" + options.labels_path + "'"
                    : "the built-in COCO names (label file '" + options.labels_path + "' not read)";
    return Status::Error(label_source + " has " + std::to_string(result->labels_.size()) +
                         " names but the " + model_name + " model '" + options.model_path +
                         "' outputs " + std::to_string(classes) +
                         " classes: give the label file of this model (one name per class, in "
                         "output order)");
  }
  *segmenter = std::move(result);
  return Status::Ok();
}

Status DnnInstanceSegmenter::detect(const cv::Mat& image_bgr, const std::string& frame_name,
                                    std::vector<Detection2D>* detections,
                                    std::vector<std::string>* warnings) {
  detections->clear();
  if (image_bgr.empty() || image_bgr.type() != CV_8UC3) {
    return Status::Error(frame_name + ": " + name() + " needs a non-empty 8-bit BGR image");
  }
  std::vector<Detection2D> decoded;
  try {
    cv::dnn::Net& net = network_->net;
    if (model_ == Model::kYoloSeg) {
      const Letterbox letterbox = Letterbox::fit(image_bgr.size(), input_px_);
      net.setInput(letterbox.blob(image_bgr));
      std::vector<cv::Mat> outputs;
      net.forward(outputs, yoloSegOutputs());
      const Status status = decodeYoloSeg(outputs[0], outputs[1], letterbox, labels_,
                                          yoloSegConfig(options_.decode), &decoded);
      if (!status) return Status::Error(frame_name + ": " + status.message());
    } else if (model_ == Model::kFastestDet) {
      net.setInput(cv::dnn::blobFromImage(image_bgr, 1.0 / 255.0,
                                          cv::Size(kFastestDetInputPx, kFastestDetInputPx),
                                          cv::Scalar(), false, false));
      const cv::Mat output = net.forward();
      const Status status =
          decodeFastestDet(output, image_bgr.size(), labels_, options_.decode, &decoded);
      if (!status) return Status::Error(frame_name + ": " + status.message());
    } else {
      // The text graph resizes internally (keep_aspect_ratio_resizer); feed the image as it is.
      net.setInput(cv::dnn::blobFromImage(image_bgr, 1.0, cv::Size(image_bgr.cols, image_bgr.rows),
                                          cv::Scalar(), true, false));
      std::vector<cv::Mat> outputs;
      net.forward(outputs, maskRcnnOutputs());
      const Status status = decodeMaskRcnn(outputs[0], outputs[1], image_bgr.size(), labels_,
                                           options_.decode, &decoded);
      if (!status) return Status::Error(frame_name + ": " + status.message());
    }
  } catch (const cv::Exception& e) {
    return Status::Error(frame_name + ": " + name() + " forward pass failed: " + e.what());
  }
  for (Detection2D& detection : decoded) {
    if (detection.class_id < 0) {
      if (warnings != nullptr) {
        warnings->push_back(name() + ": class '" + detection.class_name +
                            "' is not one of the 80 COCO classes; detection dropped");
      }
      continue;
    }
    detections->push_back(std::move(detection));
  }
  return Status::Ok();
}

}  // namespace mvod
