// Boxes in the JSON files are [x1, y1, x2, y2] in colour pixels with (x2, y2) exclusive, as in
// cv::Rect (x, y, x2 - x, y2 - y); fractional values widen the box to whole pixels. Per-entry
// problems (a wrong type, an unknown class, a missing or wrongly sized mask) skip that entry with a
// warning; a file that is not a JSON array of objects is an error.
#include "multiview_object_detection/detectors/file_instance_segmenter.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "multiview_object_detection/pipeline/class_priors.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string sizeText(const cv::Size& size) {
  return std::to_string(size.width) + "x" + std::to_string(size.height);
}

// Reads one entry; false with *problem set when the entry has to be skipped.
bool parseEntry(const json& entry, const fs::path& directory, const cv::Size& image_size,
                Detection2D* detection, std::string* problem) {
  if (!entry.is_object()) {
    *problem = "not an object";
    return false;
  }

  // Class: the name decides; "class_id" alone (without a name) is accepted when it is a COCO id.
  const auto name_it = entry.find("class_name");
  const auto id_it = entry.find("class_id");
  if (name_it != entry.end()) {
    if (!name_it->is_string()) {
      *problem = "\"class_name\" is not a string";
      return false;
    }
    detection->class_name = name_it->get<std::string>();
  } else if (id_it != entry.end() && id_it->is_number_integer()) {
    const int id = id_it->get<int>();
    const std::vector<std::string>& names = cocoClassNames();
    if (id >= 0 && id < static_cast<int>(names.size())) detection->class_name = names[id];
  }
  if (detection->class_name.empty()) {
    *problem = "no \"class_name\"";
    return false;
  }
  detection->class_id = cocoClassId(detection->class_name);
  if (detection->class_id < 0) {
    *problem = "unknown class '" + detection->class_name + "' (not a COCO class name)";
    return false;
  }
  // The COCO spelling (cocoClassId also takes aliases such as "sofa"): class names key the priors.
  detection->class_name = cocoClassNames()[detection->class_id];

  const auto score_it = entry.find("score");
  if (score_it == entry.end() || !score_it->is_number()) {
    *problem = "\"score\" missing or not a number";
    return false;
  }
  const double score = score_it->get<double>();
  if (!(score >= 0.0 && score <= 1.0)) {
    *problem = "\"score\" " + std::to_string(score) + " is not in [0, 1]";
    return false;
  }
  detection->score = static_cast<float>(score);

  const cv::Rect image_rect(0, 0, image_size.width, image_size.height);
  bool has_box = false;
  const auto box_it = entry.find("box");
  if (box_it != entry.end()) {
    if (!box_it->is_array() || box_it->size() != 4) {
      *problem = "\"box\" is not [x1, y1, x2, y2]";
      return false;
    }
    double b[4];
    for (int i = 0; i < 4; ++i) {
      if (!(*box_it)[i].is_number()) {
        *problem = "\"box\" is not [x1, y1, x2, y2] numbers";
        return false;
      }
      b[i] = (*box_it)[i].get<double>();
      if (!std::isfinite(b[i]) || std::abs(b[i]) > 1e6) {
        *problem = "\"box\" holds a non-finite or huge value";
        return false;
      }
    }
    if (!(b[2] > b[0] && b[3] > b[1])) {
      *problem = "\"box\" has x2 <= x1 or y2 <= y1";
      return false;
    }
    const int x1 = static_cast<int>(std::floor(b[0]));
    const int y1 = static_cast<int>(std::floor(b[1]));
    const int x2 = static_cast<int>(std::ceil(b[2]));
    const int y2 = static_cast<int>(std::ceil(b[3]));
    detection->box_px = cv::Rect(x1, y1, x2 - x1, y2 - y1) & image_rect;  // clipped to the image
    if (detection->box_px.empty()) {
      *problem = "\"box\" lies outside the " + sizeText(image_size) + " image";
      return false;
    }
    has_box = true;
  }

  const auto mask_it = entry.find("mask");
  if (mask_it != entry.end() && !mask_it->is_null()) {
    if (!mask_it->is_string() || mask_it->get<std::string>().empty()) {
      *problem = "\"mask\" is not a file name";
      return false;
    }
    fs::path mask_path(mask_it->get<std::string>());
    if (mask_path.is_relative()) mask_path = directory / mask_path;
    std::error_code error;
    if (!fs::is_regular_file(mask_path, error)) {
      *problem = "mask " + mask_path.string() + ": no such file";
      return false;
    }
    cv::Mat raw;
    try {
      raw = cv::imread(mask_path.string(), cv::IMREAD_UNCHANGED);
    } catch (const cv::Exception& e) {
      raw.release();
    }
    if (raw.empty()) {
      *problem = "mask " + mask_path.string() + ": cannot read the image";
      return false;
    }
    if (raw.size() != image_size) {
      *problem = "mask " + mask_path.string() + " is " + sizeText(raw.size()) +
                 ", expected the colour image's " + sizeText(image_size);
      return false;
    }
    if (raw.channels() > 1) {
      std::vector<cv::Mat> channels;
      cv::split(raw, channels);
      raw = channels[0];  // any channel will do for a binary mask
    }
    cv::compare(raw, 0, detection->mask, cv::CMP_NE);  // non-zero = object -> 255
    if (!has_box) {
      detection->box_px = cv::boundingRect(detection->mask);
      if (detection->box_px.empty()) {
        *problem = "mask " + mask_path.string() + " is empty and there is no \"box\"";
        return false;
      }
    }
  } else {
    if (!has_box) {
      *problem = "neither \"box\" nor \"mask\"";
      return false;
    }
    // A box-only detector: the box is the mask.
    detection->mask = cv::Mat::zeros(image_size, CV_8UC1);
    detection->mask(detection->box_px).setTo(255);
  }
  return true;
}

}  // namespace

Status FileInstanceSegmenter::detect(const cv::Mat& image_bgr, const std::string& frame_name,
                                     std::vector<Detection2D>* detections,
                                     std::vector<std::string>* warnings) {
  if (detections == nullptr) return Status::Error("detect: detections is null");
  detections->clear();
  if (frame_name.empty()) return Status::Error("file detector: empty frame name");
  if (image_bgr.empty()) return Status::Error("file detector: " + frame_name + ": empty image");

  const fs::path directory(directory_);
  const fs::path path = directory / (frame_name + ".json");
  std::error_code error;
  if (!fs::exists(path, error)) return Status::Ok();  // no detections for this frame

  std::ifstream in(path);
  if (!in) return Status::Error(path.string() + ": cannot be read");
  json document;
  try {
    document = json::parse(in);
  } catch (const json::exception& e) {
    return Status::Error(path.string() + ": malformed JSON: " + e.what());
  }
  if (!document.is_array()) {
    return Status::Error(path.string() +
                         ": expected a JSON array of detections [{\"class_name\", \"score\", "
                         "\"box\", \"mask\"}, ...]");
  }

  for (size_t i = 0; i < document.size(); ++i) {
    Detection2D detection;
    std::string problem;
    try {
      if (parseEntry(document[i], directory, image_bgr.size(), &detection, &problem)) {
        detections->push_back(std::move(detection));
        continue;
      }
    } catch (const json::exception& e) {
      problem = e.what();
    }
    if (warnings != nullptr) {
      warnings->push_back(path.string() + ": entry " + std::to_string(i) + ": " + problem +
                          "; skipped");
    }
  }
  return Status::Ok();
}

Status FileInstanceSegmenter::write(const std::string& directory, const std::string& frame_name,
                                    const std::vector<Detection2D>& detections) {
  if (frame_name.empty()) return Status::Error("file detector: empty frame name");
  const fs::path dir(directory);
  std::error_code error;
  fs::create_directories(dir, error);
  if (!fs::is_directory(dir, error)) {
    return Status::Error(directory + ": cannot create the folder");
  }

  json document = json::array();
  for (size_t k = 0; k < detections.size(); ++k) {
    const Detection2D& detection = detections[k];
    json entry;
    entry["class_name"] = detection.class_name;
    if (detection.class_id >= 0) entry["class_id"] = detection.class_id;
    // Six decimals: reads back as the same float and keeps the file readable.
    entry["score"] = std::round(static_cast<double>(detection.score) * 1e6) / 1e6;
    const cv::Rect& b = detection.box_px;
    entry["box"] = json::array({b.x, b.y, b.x + b.width, b.y + b.height});
    if (!detection.mask.empty()) {
      if (detection.mask.type() != CV_8UC1) {
        return Status::Error(frame_name + ": detection " + std::to_string(k) +
                             ": mask is not 8UC1");
      }
      const std::string mask_name = frame_name + "." + std::to_string(k) + ".png";
      cv::Mat binary;
      cv::compare(detection.mask, 0, binary, cv::CMP_NE);
      bool written = false;
      try {
        written = cv::imwrite((dir / mask_name).string(), binary);
      } catch (const cv::Exception& e) {
        written = false;
      }
      if (!written) return Status::Error((dir / mask_name).string() + ": cannot write the mask");
      entry["mask"] = mask_name;
    }
    document.push_back(std::move(entry));
  }

  // Temporary file + rename: a reader never sees half a file.
  const fs::path path = dir / (frame_name + ".json");
  const fs::path temporary = dir / (frame_name + ".json.tmp");
  {
    std::ofstream out(temporary);
    out << document.dump(2) << "\n";
    out.close();
    if (!out) return Status::Error(temporary.string() + ": cannot write");
  }
  fs::rename(temporary, path, error);
  if (error) return Status::Error(path.string() + ": cannot write: " + error.message());
  return Status::Ok();
}

}  // namespace mvod
