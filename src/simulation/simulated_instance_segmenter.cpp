// Label image -> degraded detections. Each random decision of an instance draws from its own
// splitmix64 stream keyed by (seed, frame number, label id, decision), always the same number of
// draws, so the result does not depend on the order frames are processed in, and e.g. a different
// bleed_probability leaves the misses as they were. Normal scores are sums of 12 uniforms
// (Irwin-Hall): plain IEEE arithmetic, the same on every platform. Morphology on binary masks
// (max/min) is exact too; the jitter field is interpolated here rather than by cv::resize, whose
// SIMD paths may round differently.
#include "multiview_object_detection/simulation/simulated_instance_segmenter.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>

#include "multiview_object_detection/datasets/class_names.h"
#include "multiview_object_detection/datasets/scenenn_annotation.h"
#include "multiview_object_detection/io/image_io.h"
#include "multiview_object_detection/pipeline/types/class_priors.h"
#include "multiview_object_detection/simulation/split_mix.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

// Decisions, one random stream each.
enum class Draw : uint64_t {
  kMiss = 1,
  kBleed = 2,
  kJitter = 3,
  kConfusion = 4,
  kScore = 5,
  kPart = 6,
  kFalsePositive = 7,
};

uint64_t hashCombine(uint64_t hash, uint64_t value) {
  SplitMix64 mixer(hash ^ (value + 0x9E3779B97F4A7C15ULL + (hash << 6) + (hash >> 2)));
  return mixer.next();
}

SplitMix64 stream(uint64_t seed, int frame_number, int label_id, Draw draw) {
  uint64_t hash = hashCombine(seed, static_cast<uint64_t>(frame_number));
  hash = hashCombine(hash, static_cast<uint64_t>(label_id));
  hash = hashCombine(hash, static_cast<uint64_t>(draw));
  return SplitMix64(hash);
}

// Lower case, trimmed, trailing digits dropped ("Chair2 " -> "chair").
std::string normaliseText(const std::string& text) {
  std::string key;
  for (const char c : text) key += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const auto isSpace = [](char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; };
  while (!key.empty() &&
         (isSpace(key.back()) || std::isdigit(static_cast<unsigned char>(key.back())) != 0)) {
    key.pop_back();
  }
  size_t begin = 0;
  while (begin < key.size() && isSpace(key[begin])) ++begin;
  return key.substr(begin);
}

// The COCO class of a label text, "" when it is not one.
std::string cocoClassOfText(const std::string& text) {
  std::string key = normaliseText(text);
  if (key.empty()) return "";
  if (key == "coffee table") key = "table";
  int id = cocoClassId(key);
  if (id < 0) id = cocoClassId(canonicalClassName(key));
  return id < 0 ? std::string() : cocoClassNames()[id];
}

bool isCocoSpelling(const std::string& name) {
  const int id = cocoClassId(name);
  return id >= 0 && cocoClassNames()[id] == name;
}

Status checkCoco(const std::string& field, const std::string& name) {
  if (isCocoSpelling(name)) return Status::Ok();
  const int id = cocoClassId(name);
  if (id >= 0) {
    return Status::Error(field + ": write '" + cocoClassNames()[id] + "' instead of '" + name +
                         "'");
  }
  return Status::Error(field + ": '" + name + "' is not a COCO class name");
}

bool isProbability(double p) { return std::isfinite(p) && p >= 0.0 && p <= 1.0; }

// Each entry's class names and probability, and the probabilities of one `from` summing to <= 1.
Status checkConfusions(const std::string& field, const std::vector<ClassConfusion>& entries,
                       bool from_is_coco) {
  std::map<std::string, double> sums;
  for (size_t i = 0; i < entries.size(); ++i) {
    const ClassConfusion& entry = entries[i];
    const std::string where = field + "[" + std::to_string(i) + "]";
    if (from_is_coco) {
      const Status status = checkCoco(where + ".from", entry.from);
      if (!status) return status;
    } else if (entry.from.empty() || normaliseText(entry.from) != entry.from) {
      return Status::Error(where + ".from: '" + entry.from +
                           "' must be a label text in lower case without trailing digits");
    }
    const Status status = checkCoco(where + ".to", entry.to);
    if (!status) return status;
    if (!isProbability(entry.probability)) {
      return Status::Error(where + ".probability must be in [0, 1]");
    }
    sums[entry.from] += entry.probability;
  }
  for (const auto& sum : sums) {
    if (sum.second > 1.0 + 1e-9) {
      return Status::Error(field + ": the probabilities of '" + sum.first + "' sum to more than 1");
    }
  }
  return Status::Ok();
}

// The entry whose cumulative probability band holds u, or nullptr.
const ClassConfusion* pickConfusion(const std::vector<ClassConfusion>& entries,
                                    const std::string& from, double u) {
  double cumulative = 0.0;
  for (const ClassConfusion& entry : entries) {
    if (entry.from != from) continue;
    cumulative += entry.probability;
    if (u < cumulative) return &entry;
  }
  return nullptr;
}

std::string sizeText(const cv::Size& size) {
  return std::to_string(size.width) + "x" + std::to_string(size.height);
}

std::string typeText(const cv::Mat& image) {
  static const char* kDepths[] = {"8U", "8S", "16U", "16S", "32S", "32F", "64F", "16F"};
  return std::string("CV_") + kDepths[image.depth()] + "C" + std::to_string(image.channels());
}

struct InstanceStats {
  int count = 0;
  int min_x = 0, min_y = 0, max_x = 0, max_y = 0;
  cv::Rect box() const { return cv::Rect(min_x, min_y, max_x - min_x + 1, max_y - min_y + 1); }
};

}  // namespace

SimulatedInstanceSegmenter::Config SimulatedInstanceSegmenter::Config::perfect() {
  Config config;
  config.miss_probability = 0.0;
  config.min_pixels = 1;
  config.small_miss_probability = 0.0;
  config.bleed_probability = 0.0;
  config.jitter_probability = 0.0;
  config.part_probability = 0.0;
  config.part_removed_probability = 0.0;
  for (ClassConfusion& entry : config.confusions) entry.probability = 0.0;
  for (ClassConfusion& entry : config.false_positives) entry.probability = 0.0;
  config.true_score_stddev = 0.0;
  config.confused_score_stddev = 0.0;
  return config;
}

Status SimulatedInstanceSegmenter::Config::isValid() const {
  const std::pair<const char*, double> probabilities[] = {
      {"miss_probability", miss_probability},
      {"small_miss_probability", small_miss_probability},
      {"bleed_probability", bleed_probability},
      {"jitter_probability", jitter_probability},
      {"part_probability", part_probability},
      {"part_removed_probability", part_removed_probability}};
  for (const auto& p : probabilities) {
    if (!isProbability(p.second)) return Status::Error(std::string(p.first) + " must be in [0, 1]");
  }
  if (min_pixels < 0) return Status::Error("min_pixels must be >= 0");
  if (small_area_px < 0) return Status::Error("small_area_px must be >= 0");
  if (!(min_bleed_px >= 1 && min_bleed_px <= max_bleed_px && max_bleed_px <= 100)) {
    return Status::Error("bleed radii must satisfy 1 <= min_bleed_px <= max_bleed_px <= 100");
  }
  if (!(jitter_px >= 1 && jitter_px <= 10)) return Status::Error("jitter_px must be in [1, 10]");
  if (!(jitter_cell_px >= 1 && jitter_cell_px <= 1000)) {
    return Status::Error("jitter_cell_px must be in [1, 1000]");
  }
  if (!(min_part_fraction > 0.0 && min_part_fraction <= max_part_fraction &&
        max_part_fraction < 1.0)) {
    return Status::Error(
        "part fractions must satisfy 0 < min_part_fraction <= max_part_fraction < 1");
  }
  for (const auto& entry : part_classes) {
    Status status = checkCoco("part_classes key", entry.first);
    if (!status) return status;
    if (!(status = checkCoco("part_classes['" + entry.first + "']", entry.second))) return status;
  }
  Status status = checkConfusions("confusions", confusions, true);
  if (!status) return status;
  if (!(status = checkConfusions("false_positives", false_positives, false))) return status;
  const std::pair<const char*, double> means[] = {{"true_score_mean", true_score_mean},
                                                  {"confused_score_mean", confused_score_mean}};
  for (const auto& m : means) {
    if (!isProbability(m.second)) return Status::Error(std::string(m.first) + " must be in [0, 1]");
  }
  if (!(std::isfinite(true_score_stddev) && true_score_stddev >= 0.0 &&
        std::isfinite(confused_score_stddev) && confused_score_stddev >= 0.0)) {
    return Status::Error("score standard deviations must be finite and >= 0");
  }
  if (!(isProbability(min_score) && isProbability(max_score) && min_score <= max_score)) {
    return Status::Error("scores must satisfy 0 <= min_score <= max_score <= 1");
  }
  return Status::Ok();
}

SimulatedInstanceSegmenter::SimulatedInstanceSegmenter(std::string directory, Config config)
    : directory_(std::move(directory)), config_(std::move(config)) {}

Status SimulatedInstanceSegmenter::create(const std::string& directory, const Config& config,
                                          std::unique_ptr<SimulatedInstanceSegmenter>* segmenter) {
  if (segmenter == nullptr) return Status::Error("simulated detector: null output");
  segmenter->reset();
  if (directory.empty()) {
    return Status::Error(
        "simulated detector: no sequence folder given (a SceneNN-layout folder "
        "with <id>.xml and label/labelNNNNN.png)");
  }
  std::error_code error;
  if (!fs::is_directory(directory, error)) {
    return Status::Error(directory +
                         ": no such folder (the simulated detector needs a SceneNN-layout "
                         "sequence with <id>.xml and label/labelNNNNN.png)");
  }
  const Status valid = config.isValid();
  if (!valid) return Status::Error("simulated detector: " + valid.message());

  fs::path dir = fs::path(directory).lexically_normal();
  if (dir.filename().empty()) dir = dir.parent_path();
  const fs::path xml_path = dir / (dir.filename().string() + ".xml");
  if (!fs::is_regular_file(xml_path, error)) {
    return Status::Error(xml_path.string() +
                         ": no such file (the simulated detector needs the sequence's SceneNN "
                         "annotation)");
  }
  std::vector<SceneNNLabel> labels;
  const Status read = readSceneNNXml(xml_path.string(), &labels);
  if (!read) return read;

  std::unique_ptr<SimulatedInstanceSegmenter> result(
      new SimulatedInstanceSegmenter(dir.string(), config));
  for (const SceneNNLabel& label : labels) {
    // The text first (the benchmark writes COCO names there), then NYU's class.
    std::string coco = cocoClassOfText(label.text);
    if (coco.empty()) coco = cocoClassOfText(label.nyu_class);
    result->label_classes_[label.id] = coco;
    result->label_texts_[label.id] = normaliseText(label.text);
  }
  *segmenter = std::move(result);
  return Status::Ok();
}

std::string SimulatedInstanceSegmenter::labelImagePath(int frame_number) const {
  char name[32];
  std::snprintf(name, sizeof(name), "label%05d.png", frame_number);
  return (fs::path(directory_) / "label" / name).string();
}

namespace {

// Bleed (elliptical dilation) and boundary jitter of `mask` (full image, 0/255), in place. Only the
// region around `box` is touched.
void degradeMask(const SimulatedInstanceSegmenter::Config& config, SplitMix64* bleed_rng,
                 SplitMix64* jitter_rng, const cv::Rect& box, cv::Mat* mask) {
  const int margin = config.max_bleed_px + config.jitter_px + 1;
  const cv::Rect work =
      cv::Rect(box.x - margin, box.y - margin, box.width + 2 * margin, box.height + 2 * margin) &
      cv::Rect(0, 0, mask->cols, mask->rows);
  cv::Mat region = (*mask)(work);

  // The same draws whatever the outcome.
  const bool bleed = bleed_rng->bernoulli(config.bleed_probability);
  const int radius_x = bleed_rng->uniformInt(config.min_bleed_px, config.max_bleed_px);
  const int radius_y = bleed_rng->uniformInt(config.min_bleed_px, config.max_bleed_px);
  if (bleed) {
    const cv::Mat kernel =
        cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * radius_x + 1, 2 * radius_y + 1));
    cv::Mat bled;
    cv::dilate(region, bled, kernel);
    bled.copyTo(region);
  }

  if (!jitter_rng->bernoulli(config.jitter_probability)) return;
  // A smooth random field in [0, 1): bilinear between values on a grid of jitter_cell_px cells.
  const int cell = config.jitter_cell_px;
  const int grid_w = work.width / cell + 2;
  const int grid_h = work.height / cell + 2;
  std::vector<double> grid(static_cast<size_t>(grid_w) * grid_h);
  for (double& value : grid) value = jitter_rng->uniform();
  const cv::Mat kernel = cv::getStructuringElement(
      cv::MORPH_ELLIPSE, cv::Size(2 * config.jitter_px + 1, 2 * config.jitter_px + 1));
  cv::Mat grown, shrunk;
  cv::dilate(region, grown, kernel);
  cv::erode(region, shrunk, kernel);
  for (int y = 0; y < work.height; ++y) {
    const double gy = static_cast<double>(y) / cell;
    const int y0 = static_cast<int>(gy);
    const double fy = gy - y0;
    const uchar* g = grown.ptr<uchar>(y);
    const uchar* s = shrunk.ptr<uchar>(y);
    uchar* out = region.ptr<uchar>(y);
    for (int x = 0; x < work.width; ++x) {
      if (g[x] == s[x]) continue;  // not on the boundary
      const double gx = static_cast<double>(x) / cell;
      const int x0 = static_cast<int>(gx);
      const double fx = gx - x0;
      const double* row0 = &grid[static_cast<size_t>(y0) * grid_w];
      const double* row1 = row0 + grid_w;
      const double value = (1.0 - fy) * ((1.0 - fx) * row0[x0] + fx * row0[x0 + 1]) +
                           fy * ((1.0 - fx) * row1[x0] + fx * row1[x0 + 1]);
      out[x] = value >= 0.5 ? g[x] : s[x];
    }
  }
}

// The frame number a frame name ends with ("image00001" -> 1).
Status frameNumberOf(const std::string& frame_name, int* frame_number) {
  size_t digits_begin = frame_name.size();
  while (digits_begin > 0 &&
         std::isdigit(static_cast<unsigned char>(frame_name[digits_begin - 1])) != 0) {
    --digits_begin;
  }
  const size_t num_digits = frame_name.size() - digits_begin;
  if (num_digits == 0 || num_digits > 9) {
    return Status::Error("simulated detector: frame name '" + frame_name +
                         "' does not end with a frame number (expected e.g. image00001)");
  }
  *frame_number = std::stoi(frame_name.substr(digits_begin));
  return Status::Ok();
}

// The frame's 16-bit label image, of the colour image's size. The size is checked from the PNG
// header before decoding (a small file can claim 20000x20000).
Status readLabelImage(const std::string& path, const cv::Size& image_size, cv::Mat* labels) {
  std::error_code error;
  if (!fs::is_regular_file(path, error)) {
    return Status::Error(path +
                         ": no such file (the simulated detector needs the frame's "
                         "instance label image)");
  }
  const Status read = readImageChecked(path, cv::IMREAD_UNCHANGED, image_size,
                                       int64_t{image_size.width} * image_size.height, labels,
                                       "the colour image's size");
  if (!read) return read;
  if (labels->type() != CV_16UC1) {
    return Status::Error(path + ": label image is " + typeText(*labels) +
                         ", expected a 16-bit single-channel PNG (CV_16UC1)");
  }
  if (labels->size() != image_size) {
    return Status::Error(path + ": label image is " + sizeText(labels->size()) +
                         ", expected the colour image's " + sizeText(image_size));
  }
  return Status::Ok();
}

// Area and bounding box of every label id in one pass.
std::vector<InstanceStats> instanceStats(const cv::Mat& labels) {
  std::vector<InstanceStats> stats(65536);
  for (int y = 0; y < labels.rows; ++y) {
    const uint16_t* row = labels.ptr<uint16_t>(y);
    for (int x = 0; x < labels.cols; ++x) {
      if (row[x] == 0) continue;
      InstanceStats& s = stats[row[x]];
      if (s.count++ == 0) {
        s.min_x = s.max_x = x;
        s.min_y = s.max_y = y;
      } else {
        s.min_x = std::min(s.min_x, x);
        s.max_x = std::max(s.max_x, x);
        s.max_y = y;  // rows ascend
      }
    }
  }
  return stats;
}

// What the detector reports instance `id` as: its class (maybe confused), or for clutter (empty
// true_class) a false positive. False: missed, or clutter taken for nothing.
bool reportedClass(const SimulatedInstanceSegmenter::Config& c, int frame_number, int id, int count,
                   const std::string& true_class, const std::string& label_text,
                   std::string* detected_class, bool* confused) {
  *detected_class = true_class;
  *confused = false;
  if (true_class.empty()) {
    SplitMix64 rng = stream(c.seed, frame_number, id, Draw::kFalsePositive);
    const ClassConfusion* fp = pickConfusion(c.false_positives, label_text, rng.uniform());
    if (fp == nullptr) return false;
    *detected_class = fp->to;
    *confused = true;
    return true;
  }
  SplitMix64 miss_rng = stream(c.seed, frame_number, id, Draw::kMiss);
  double miss_probability = c.miss_probability;
  if (count < c.small_area_px && c.small_area_px > c.min_pixels) {
    const double t = static_cast<double>(c.small_area_px - count) /
                     static_cast<double>(c.small_area_px - c.min_pixels);
    miss_probability += (c.small_miss_probability - c.miss_probability) * t;
  }
  if (miss_rng.bernoulli(miss_probability)) return false;
  SplitMix64 rng = stream(c.seed, frame_number, id, Draw::kConfusion);
  const ClassConfusion* confusion = pickConfusion(c.confusions, true_class, rng.uniform());
  if (confusion != nullptr) {
    *detected_class = confusion->to;
    *confused = true;
  }
  return true;
}

float clipScore(const SimulatedInstanceSegmenter::Config& c, double score) {
  return static_cast<float>(std::min(c.max_score, std::max(c.min_score, score)));
}

Detection2D makeDetection(const std::string& class_name, float score, cv::Mat mask) {
  Detection2D detection;
  detection.class_name = class_name;
  detection.class_id = cocoClassId(class_name);
  detection.score = score;
  detection.box_px = cv::boundingRect(mask);
  detection.mask = std::move(mask);
  return detection;
}

// A part of a real object as a separate detection of a confusable class (an empty mask when
// none); with part_removed_probability it is also cut out of *mask.
Detection2D partDetection(const SimulatedInstanceSegmenter::Config& c, int frame_number, int id,
                          const std::string& true_class, float score, double part_score,
                          cv::Mat* mask) {
  SplitMix64 rng = stream(c.seed, frame_number, id, Draw::kPart);
  const bool split = rng.bernoulli(c.part_probability);
  const int side = rng.uniformInt(0, 3);  // top, bottom, left, right
  const double fraction =
      c.min_part_fraction + (c.max_part_fraction - c.min_part_fraction) * rng.uniform();
  const bool removed = rng.bernoulli(c.part_removed_probability);
  const auto part_class = c.part_classes.find(true_class);
  if (!split || part_class == c.part_classes.end()) return Detection2D();
  const cv::Rect extent = cv::boundingRect(*mask);
  cv::Rect strip = extent;
  if (side <= 1) {
    strip.height = std::max(1, static_cast<int>(std::lround(fraction * extent.height)));
    if (side == 1) strip.y = extent.y + extent.height - strip.height;
  } else {
    strip.width = std::max(1, static_cast<int>(std::lround(fraction * extent.width)));
    if (side == 3) strip.x = extent.x + extent.width - strip.width;
  }
  cv::Mat part_mask = cv::Mat::zeros(mask->size(), CV_8UC1);
  (*mask)(strip).copyTo(part_mask(strip));
  const int part_pixels = cv::countNonZero(part_mask);
  if (part_pixels < std::max(1, c.min_pixels)) return Detection2D();
  // Never above the instance's own score: the part is the less convincing reading.
  Detection2D part = makeDetection(part_class->second,
                                   std::min(clipScore(c, part_score), 0.9f * score), part_mask);
  if (removed && part_pixels < cv::countNonZero(*mask)) (*mask)(strip).setTo(0);
  return part;
}

}  // namespace

Status SimulatedInstanceSegmenter::detect(const cv::Mat& image_bgr, const std::string& frame_name,
                                          std::vector<Detection2D>* detections,
                                          std::vector<std::string>* warnings) {
  if (detections == nullptr) return Status::Error("detect: detections is null");
  detections->clear();
  if (image_bgr.empty()) {
    return Status::Error("simulated detector: " + frame_name + ": empty image");
  }
  int frame_number = 0;
  Status status = frameNumberOf(frame_name, &frame_number);
  if (!status) return status;
  const std::string path = labelImagePath(frame_number);
  cv::Mat labels;
  if (!(status = readLabelImage(path, image_bgr.size(), &labels))) return status;
  const std::vector<InstanceStats> stats = instanceStats(labels);
  for (int id = 1; id < static_cast<int>(stats.size()); ++id) {
    const InstanceStats& s = stats[id];
    if (s.count == 0) continue;
    const auto class_it = label_classes_.find(id);
    if (class_it == label_classes_.end()) {
      if (warnings != nullptr) {
        warnings->push_back(path + ": label id " + std::to_string(id) +
                            " is not in the sequence's XML; its " + std::to_string(s.count) +
                            " pixels are skipped");
      }
      continue;
    }
    const std::string& true_class = class_it->second;
    if (s.count < config_.min_pixels) continue;  // too small for any detector
    detectInstance(labels, frame_number, id, s.box(), s.count, true_class, detections);
  }
  return Status::Ok();
}

void SimulatedInstanceSegmenter::detectInstance(const cv::Mat& labels, int frame_number, int id,
                                                const cv::Rect& box, int count,
                                                const std::string& true_class,
                                                std::vector<Detection2D>* detections) {
  const Config& c = config_;
  std::string detected_class;
  bool confused = false;
  static const std::string kNoText;
  const std::string& label_text = true_class.empty() ? label_texts_[id] : kNoText;
  if (!reportedClass(c, frame_number, id, count, true_class, label_text, &detected_class,
                     &confused)) {
    return;
  }
  cv::Mat mask = cv::Mat::zeros(labels.size(), CV_8UC1);
  cv::Mat(labels(box) == id).copyTo(mask(box));
  SplitMix64 bleed_rng = stream(c.seed, frame_number, id, Draw::kBleed);
  SplitMix64 jitter_rng = stream(c.seed, frame_number, id, Draw::kJitter);
  degradeMask(c, &bleed_rng, &jitter_rng, box, &mask);
  if (cv::countNonZero(mask) == 0) return;  // jitter ate a sliver

  SplitMix64 score_rng = stream(c.seed, frame_number, id, Draw::kScore);
  const double true_score = score_rng.irwinHallNormal(c.true_score_mean, c.true_score_stddev);
  const double confused_score =
      score_rng.irwinHallNormal(c.confused_score_mean, c.confused_score_stddev);
  const double part_score =
      score_rng.irwinHallNormal(c.confused_score_mean, c.confused_score_stddev);
  const float score = clipScore(c, confused ? confused_score : true_score);
  Detection2D part;
  if (!true_class.empty()) {
    part = partDetection(c, frame_number, id, true_class, score, part_score, &mask);
  }
  detections->push_back(makeDetection(detected_class, score, std::move(mask)));
  if (!part.mask.empty()) detections->push_back(std::move(part));
}

}  // namespace mvod
