// Boxes in the JSON files are [x1, y1, x2, y2] in colour pixels with (x2, y2) exclusive, as in
// cv::Rect (x, y, x2 - x, y2 - y); fractional values widen the box to whole pixels. Per-entry
// problems (a wrong type, an unknown class, a missing or wrongly sized mask) skip that entry with a
// warning; a file that is not a JSON array of objects is an error.
#include "multiview_object_detection/detectors/file_instance_segmenter.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "multiview_object_detection/io/file_io.h"
#include "multiview_object_detection/io/image_io.h"
#include "multiview_object_detection/pipeline/types/class_priors.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string sizeText(const cv::Size& size) {
  return std::to_string(size.width) + "x" + std::to_string(size.height);
}

// "%g" of a number, for messages (std::to_string(1e30) prints 31 digits).
std::string numberText(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", value);
  return text;
}

// One entry that passed the cheap checks (class, score, box); its mask is made only if it is kept.
struct Candidate {
  size_t entry = 0;  // index in the document
  Detection2D detection;
  bool has_box = false;
  fs::path mask_path;  // empty: the box is the mask
};

// The entry's class: the name decides; "class_id" alone (without a name) is accepted when it is a
// COCO id. Names take the COCO spelling (cocoClassId also takes aliases such as "sofa"): class
// names key the priors.
bool parseClass(const json& entry, Detection2D* detection, std::string* problem) {
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
  detection->class_name = cocoClassNames()[detection->class_id];
  return true;
}

bool parseScore(const json& entry, Detection2D* detection, std::string* problem) {
  const auto score_it = entry.find("score");
  if (score_it == entry.end() || !score_it->is_number()) {
    *problem = "\"score\" missing or not a number";
    return false;
  }
  const double score = score_it->get<double>();
  if (!std::isfinite(score) || score < 0.0 || score > 1.0) {
    *problem = "\"score\" " + numberText(score) + " is not a probability in [0, 1]" +
               (std::isfinite(score) && score > 1.0 && score <= 100.0 ? " (a percentage?)" : "");
    return false;
  }
  detection->score = static_cast<float>(score);
  return true;
}

// The optional "box" [x1, y1, x2, y2], clipped to the image; *has_box tells whether there is one.
bool parseBox(const json& entry, const cv::Size& image_size, Detection2D* detection, bool* has_box,
              std::string* problem) {
  *has_box = false;
  const auto box_it = entry.find("box");
  if (box_it == entry.end()) return true;
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
  const cv::Rect image_rect(0, 0, image_size.width, image_size.height);
  detection->box_px = cv::Rect(x1, y1, x2 - x1, y2 - y1) & image_rect;  // clipped to the image
  if (detection->box_px.empty()) {
    *problem = "\"box\" lies outside the " + sizeText(image_size) + " image";
    return false;
  }
  *has_box = true;
  return true;
}

// The optional "mask_cell_px" (Detection2D::mask_cell_px; absent = 0).
bool parseMaskCell(const json& entry, Detection2D* detection, std::string* problem) {
  const auto cell_it = entry.find("mask_cell_px");
  if (cell_it == entry.end() || cell_it->is_null()) return true;
  const double cell_px = cell_it->is_number() ? cell_it->get<double>() : -1.0;
  if (!std::isfinite(cell_px) || cell_px < 0.0 || cell_px > 1e4) {
    *problem = "\"mask_cell_px\" is not a number of pixels in [0, 10000]";
    return false;
  }
  detection->mask_cell_px = static_cast<float>(cell_px);
  return true;
}

// Reads one entry without touching its mask file; false with *problem set when the entry has to
// be skipped.
bool parseEntry(const json& entry, const fs::path& directory, const cv::Size& image_size,
                Candidate* candidate, std::string* problem) {
  Detection2D* detection = &candidate->detection;
  if (!entry.is_object()) {
    *problem = "not an object";
    return false;
  }
  bool has_box = false;
  if (!parseClass(entry, detection, problem) || !parseScore(entry, detection, problem) ||
      !parseBox(entry, image_size, detection, &has_box, problem) ||
      !parseMaskCell(entry, detection, problem)) {
    return false;
  }
  const auto mask_it = entry.find("mask");
  if (mask_it != entry.end() && !mask_it->is_null()) {
    if (!mask_it->is_string() || mask_it->get<std::string>().empty()) {
      *problem = "\"mask\" is not a file name";
      return false;
    }
    candidate->mask_path = fs::path(mask_it->get<std::string>());
    if (candidate->mask_path.is_relative()) {
      candidate->mask_path = directory / candidate->mask_path;
    }
  } else if (!has_box) {
    *problem = "neither \"box\" nor \"mask\"";
    return false;
  }
  candidate->has_box = has_box;
  return true;
}

// Reads the candidate's mask (or fills its box); false with *problem set when it has to be
// skipped. The mask file's size is checked from its header before it is decoded.
bool makeMask(const cv::Size& image_size, Candidate* candidate, std::string* problem) {
  Detection2D* detection = &candidate->detection;
  const bool has_box = candidate->has_box;
  if (!candidate->mask_path.empty()) {
    const fs::path& mask_path = candidate->mask_path;
    cv::Mat raw;
    const Status read = readImageChecked(mask_path.string(), cv::IMREAD_UNCHANGED, image_size,
                                         int64_t{image_size.width} * image_size.height, &raw,
                                         "the colour image's size");
    if (!read) {
      *problem = "mask " + read.message();
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
    // A box-only detector: the box is the mask.
    detection->mask = cv::Mat::zeros(image_size, CV_8UC1);
    detection->mask(detection->box_px).setTo(255);
  }
  return true;
}

}  // namespace

FileInstanceSegmenter::FileInstanceSegmenter(std::string directory)
    : FileInstanceSegmenter(std::move(directory), Config()) {}

Status FileInstanceSegmenter::Config::isValid() const {
  if (max_detections < 1) return Status::Error("max_detections must be >= 1");
  return Status::Ok();
}

Status FileInstanceSegmenter::detect(const cv::Mat& image_bgr, const std::string& frame_name,
                                     std::vector<Detection2D>* detections,
                                     std::vector<std::string>* warnings) {
  if (detections == nullptr) return Status::Error("detect: detections is null");
  detections->clear();
  if (frame_name.empty()) return Status::Error("file detector: empty frame name");
  if (image_bgr.empty()) return Status::Error("file detector: " + frame_name + ": empty image");
  const Status valid = config_.isValid();
  if (!valid) return Status::Error("file detector: " + valid.message());

  const fs::path directory(directory_);
  const fs::path path = directory / (frame_name + ".json");
  std::error_code error;
  const fs::file_status status = fs::status(path, error);
  if (status.type() == fs::file_type::not_found) return Status::Ok();  // no detections here
  if (error) return Status::Error(path.string() + ": cannot be read: " + error.message());
  // A folder or a FIFO is an error, not an exception or a blocked read; so is a larger file.
  std::string text;
  const Status read = readFile(path.string(), &text, static_cast<size_t>(kMaxDetectionFileBytes));
  if (!read) return Status::Error(read.message() + " (expected a JSON array of detections)");
  return parseDetections(text, path.string(), directory_, image_bgr.size(), config_, detections,
                         warnings);
}

Status FileInstanceSegmenter::parseDetections(const std::string& text, const std::string& source,
                                              const std::string& mask_directory,
                                              const cv::Size& image_size, const Config& config,
                                              std::vector<Detection2D>* detections,
                                              std::vector<std::string>* warnings) {
  if (detections == nullptr) return Status::Error("parseDetections: detections is null");
  detections->clear();
  if (image_size.width <= 0 || image_size.height <= 0) {
    return Status::Error(source + ": empty colour image");
  }
  const Status valid = config.isValid();
  if (!valid) return Status::Error(source + ": " + valid.message());
  json document;
  try {
    document = json::parse(text);
  } catch (const std::exception& e) {  // json::exception, std::bad_alloc
    return Status::Error(source + ": malformed JSON: " + e.what());
  }
  if (!document.is_array()) {
    return Status::Error(source +
                         ": expected a JSON array of detections [{\"class_name\", \"score\", "
                         "\"box\", \"mask\"}, ...]");
  }

  // Warnings in entry order, whichever pass found them.
  std::vector<std::pair<size_t, std::string>> problems;
  const auto skip = [&problems](size_t entry, const std::string& problem) {
    problems.emplace_back(entry, problem);
  };

  // Pass 1: the cheap checks (class, score, box) on every entry; no mask is read or made yet.
  const fs::path directory(mask_directory);
  std::vector<Candidate> candidates;
  for (size_t i = 0; i < document.size(); ++i) {
    Candidate candidate;
    candidate.entry = i;
    std::string problem;
    try {
      if (parseEntry(document[i], directory, image_size, &candidate, &problem)) {
        candidates.push_back(std::move(candidate));
        continue;
      }
    } catch (const json::exception& e) {
      problem = e.what();
    }
    skip(i, problem);
  }

  // Pass 2: masks for the highest scores only, at most max_detections (each mask costs an image).
  // Equal scores keep the file's order.
  std::vector<size_t> order(candidates.size());
  for (size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(), [&candidates](size_t a, size_t b) {
    return candidates[a].detection.score > candidates[b].detection.score;
  });
  const size_t max_detections = static_cast<size_t>(config.max_detections);
  std::vector<size_t> kept;
  size_t next = 0;
  for (; next < order.size() && kept.size() < max_detections; ++next) {
    Candidate& candidate = candidates[order[next]];
    std::string problem;
    if (makeMask(image_size, &candidate, &problem)) {
      kept.push_back(order[next]);
    } else {
      skip(candidate.entry, problem);
    }
  }
  const size_t dropped = order.size() - next;

  // The file's order for what is kept.
  std::sort(kept.begin(), kept.end());
  for (const size_t k : kept) detections->push_back(std::move(candidates[k].detection));

  if (warnings != nullptr) {
    std::stable_sort(problems.begin(), problems.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& problem : problems) {
      warnings->push_back(source + ": entry " + std::to_string(problem.first) + ": " +
                          problem.second + "; skipped");
    }
    if (dropped > 0) {
      warnings->push_back(
          source + ": " + std::to_string(kept.size() + dropped) +
          " detections passed the checks, more than max_detections " +
          std::to_string(config.max_detections) + ": kept the " + std::to_string(kept.size()) +
          " highest scores, dropped " + std::to_string(dropped) +
          " (scores <= " + numberText(candidates[order[next]].detection.score) + ")");
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
    if (detection.mask_cell_px > 0.f) {
      entry["mask_cell_px"] = std::round(static_cast<double>(detection.mask_cell_px) * 1e3) / 1e3;
    }
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
