#include "multiview_object_detection/pipeline/types/class_priors.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

namespace mvod {

bool ClassPrior::hasLargeHorizontalSurface() const {
  if (flat_top) return true;
  return on_floor && has_size && std::min(size_m.x(), size_m.y()) >= kLargeSurfaceM;
}

bool ClassPrior::liesFlat() const {
  return !on_floor && has_size && size_m.minCoeff() <= kFlatEdgeM;
}

const std::vector<std::string>& cocoClassNames() {
  // The 80 COCO 2017 category names in contiguous order (YOLO / FastestDet output order).
  static const std::vector<std::string> kNames = {"person",        "bicycle",      "car",
                                                  "motorcycle",    "airplane",     "bus",
                                                  "train",         "truck",        "boat",
                                                  "traffic light", "fire hydrant", "stop sign",
                                                  "parking meter", "bench",        "bird",
                                                  "cat",           "dog",          "horse",
                                                  "sheep",         "cow",          "elephant",
                                                  "bear",          "zebra",        "giraffe",
                                                  "backpack",      "umbrella",     "handbag",
                                                  "tie",           "suitcase",     "frisbee",
                                                  "skis",          "snowboard",    "sports ball",
                                                  "kite",          "baseball bat", "baseball glove",
                                                  "skateboard",    "surfboard",    "tennis racket",
                                                  "bottle",        "wine glass",   "cup",
                                                  "fork",          "knife",        "spoon",
                                                  "bowl",          "banana",       "apple",
                                                  "sandwich",      "orange",       "broccoli",
                                                  "carrot",        "hot dog",      "pizza",
                                                  "donut",         "cake",         "chair",
                                                  "couch",         "potted plant", "bed",
                                                  "dining table",  "toilet",       "tv",
                                                  "laptop",        "mouse",        "remote",
                                                  "keyboard",      "cell phone",   "microwave",
                                                  "oven",          "toaster",      "sink",
                                                  "refrigerator",  "book",         "clock",
                                                  "vase",          "scissors",     "teddy bear",
                                                  "hair drier",    "toothbrush"};
  return kNames;
}

namespace {

// Darknet's coco.names (FastestDet's label file) spells six classes the VOC way; they name the same
// COCO class, so detections labelled with them are not lost.
const std::map<std::string, std::string>& darknetAliases() {
  static const std::map<std::string, std::string> kAliases = {
      {"motorbike", "motorcycle"},     {"aeroplane", "airplane"},       {"sofa", "couch"},
      {"pottedplant", "potted plant"}, {"diningtable", "dining table"}, {"tvmonitor", "tv"}};
  return kAliases;
}

// The COCO spelling of `class_name` (aliases resolved), or "" if it is not a COCO class.
std::string canonicalCocoName(const std::string& class_name) {
  const std::vector<std::string>& names = cocoClassNames();
  if (std::find(names.begin(), names.end(), class_name) != names.end()) return class_name;
  const auto alias = darknetAliases().find(class_name);
  return alias == darknetAliases().end() ? std::string() : alias->second;
}

// Edit distance counting a swap of two neighbouring letters as one edit ("chiar" is one from
// "chair").
size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<std::vector<size_t>> d(a.size() + 1, std::vector<size_t>(b.size() + 1));
  for (size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t substitution = d[i - 1][j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1);
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, substitution});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) {
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
      }
    }
  }
  return d[a.size()][b.size()];
}

// "'chiar' is not a COCO class name (did you mean 'chair'?)": one suggestion, never the whole list.
std::string notCocoMessage(const std::string& class_name) {
  std::string best;
  size_t best_distance = std::string::npos;
  for (const std::string& name : cocoClassNames()) {
    const size_t d = editDistance(class_name, name);
    if (d < best_distance) {
      best_distance = d;
      best = name;
    }
  }
  std::string message = "'" + class_name + "' is not a COCO class name";
  if (best_distance > std::max<size_t>(2, class_name.size() / 3) && class_name.size() >= 3) {
    // "table" -> "dining table", "plant" -> "potted plant".
    for (const std::string& name : cocoClassNames()) {
      if (name.find(class_name) != std::string::npos) {
        best = name;
        best_distance = 0;
        break;
      }
    }
  }
  if (best_distance <= std::max<size_t>(2, class_name.size() / 3)) {
    message += " (did you mean '" + best + "'?)";
  } else {
    message += " (the 80 names of cocoClassNames(), e.g. 'chair', 'dining table', 'tv')";
  }
  return message;
}

std::string describe(const YAML::Node& node) {
  if (!node.IsDefined() || node.IsNull()) return "nothing";
  if (node.IsScalar()) return "'" + node.Scalar() + "'";
  if (node.IsSequence()) return "a list of " + std::to_string(node.size());
  return "a map";
}

// A finite number, or false (no throw) for anything else.
bool readNumber(const YAML::Node& node, double* value) {
  if (!node.IsScalar()) return false;
  try {
    *value = node.as<double>();
  } catch (const YAML::Exception&) {
    return false;
  }
  return std::isfinite(*value);
}

Status readDistance(const YAML::Node& node, const std::string& where, double* distance_m) {
  double value = 0.0;
  if (!readNumber(node, &value) || value < 0.0) {
    return Status::Error(where + " must be a finite distance >= 0 in metres (got " +
                         describe(node) + ")");
  }
  *distance_m = value;
  return Status::Ok();
}

Status parseClass(const YAML::Node& value, const std::string& where, double default_distance_m,
                  ClassPrior* prior) {
  prior->fusion_distance_m = default_distance_m;
  if (value.IsNull()) return Status::Ok();  // "chair:" alone: listed, no size, default distance
  if (!value.IsMap()) {
    return Status::Error(where + " must be a map {size_m: [l, w, h], fusion_distance_m: d} (got " +
                         describe(value) + ")");
  }
  for (const auto& field : value) {
    const std::string key = field.first.IsScalar() ? field.first.Scalar() : std::string("?");
    if (key == "size_m") {
      const YAML::Node& size = field.second;
      bool good = size.IsSequence() && size.size() == 3;
      for (int i = 0; good && i < 3; ++i) {
        good = readNumber(size[i], &prior->size_m[i]) && prior->size_m[i] > 0.0;
      }
      if (!good) {
        std::string got = describe(size);
        if (size.IsSequence()) {
          std::ostringstream items;
          items << "[";
          for (size_t i = 0; i < size.size(); ++i) {
            items << (i ? ", " : "") << (size[i].IsScalar() ? size[i].Scalar() : "?");
          }
          items << "]";
          got = items.str();
        }
        return Status::Error(where + ".size_m must be 3 positive finite lengths in metres " +
                             "[length, width, height] (got " + got + ")");
      }
      prior->has_size = true;
    } else if (key == "fusion_distance_m") {
      const Status status =
          readDistance(field.second, where + ".fusion_distance_m", &prior->fusion_distance_m);
      if (!status) return status;
    } else if (key == "amodal_depth_m") {
      const Status status =
          readDistance(field.second, where + ".amodal_depth_m", &prior->amodal_depth_m);
      if (!status) return status;
    } else if (key == "on_floor" || key == "flat_top" || key == "on_wall") {
      bool flag = false;
      try {
        if (!field.second.IsScalar()) throw YAML::Exception(YAML::Mark(), "not a scalar");
        flag = field.second.as<bool>();
      } catch (const YAML::Exception&) {
        return Status::Error(where + "." + key + " must be true or false (got " +
                             describe(field.second) + ")");
      }
      (key == "on_floor"   ? prior->on_floor
       : key == "flat_top" ? prior->flat_top
                           : prior->on_wall) = flag;
    } else {
      return Status::Error(where + ": unknown key '" + key +
                           "' (expected size_m, fusion_distance_m, on_floor, flat_top, "
                           "on_wall, amodal_depth_m)");
    }
  }
  return Status::Ok();
}

Status parseRoot(const YAML::Node& root, ClassPriors* parsed) {
  if (!root.IsDefined() || root.IsNull()) {
    return Status::Error("empty document (expected default_fusion_distance_m and classes)");
  }
  if (!root.IsMap()) {
    return Status::Error(
        "the top level must be a map with default_fusion_distance_m and classes (got " +
        describe(root) + ")");
  }
  // Read the default first: class entries without a distance inherit it wherever it is written.
  for (const auto& entry : root) {
    const std::string key = entry.first.IsScalar() ? entry.first.Scalar() : std::string("?");
    if (key == "default_fusion_distance_m") {
      const Status status = readDistance(entry.second, key, &parsed->default_fusion_distance_m);
      if (!status) return status;
    } else if (key != "classes") {
      return Status::Error("unknown top-level key '" + key +
                           "' (expected default_fusion_distance_m and classes)");
    }
  }
  const YAML::Node classes = root["classes"];
  if (!classes.IsDefined() || classes.IsNull()) return Status::Ok();
  if (!classes.IsMap()) {
    return Status::Error(
        "classes must be a map of class name -> {size_m, fusion_distance_m} (got " +
        describe(classes) + ")");
  }
  for (const auto& entry : classes) {
    if (!entry.first.IsScalar()) return Status::Error("classes: a class name must be a string");
    const std::string name = entry.first.Scalar();
    const std::string where = "classes." + name;
    const std::string canonical = canonicalCocoName(name);
    if (canonical.empty()) return Status::Error(where + ": " + notCocoMessage(name));
    if (parsed->find(canonical) != nullptr) {
      return Status::Error(where + ": class '" + canonical + "' is listed twice");
    }
    ClassPrior prior;
    prior.class_name = canonical;
    const Status status =
        parseClass(entry.second, where, parsed->default_fusion_distance_m, &prior);
    if (!status) return status;
    parsed->set(prior);
  }
  return Status::Ok();
}

}  // namespace

int cocoClassId(const std::string& class_name) {
  const std::string canonical = canonicalCocoName(class_name);
  if (canonical.empty()) return -1;
  const std::vector<std::string>& names = cocoClassNames();
  return static_cast<int>(std::find(names.begin(), names.end(), canonical) - names.begin());
}

namespace {

// Parses into a fresh ClassPriors; the message names the entry but not the source.
Status parseText(const std::string& yaml_text, ClassPriors* parsed) {
  try {
    return parseRoot(YAML::Load(yaml_text), parsed);
  } catch (const YAML::Exception& e) {
    return Status::Error(std::string("YAML syntax error: ") + e.what());
  } catch (const std::exception& e) {
    return Status::Error(std::string("cannot parse: ") + e.what());
  }
}

}  // namespace

Status ClassPriors::parseYaml(const std::string& yaml_text, ClassPriors* priors) {
  if (priors == nullptr) return Status::Error("class priors: null output");
  ClassPriors parsed;  // filled completely before *priors is touched
  const Status status = parseText(yaml_text, &parsed);
  if (!status) return Status::Error("class priors: " + status.message());
  *priors = std::move(parsed);
  return Status::Ok();
}

Status ClassPriors::loadYaml(const std::string& path, ClassPriors* priors) {
  if (priors == nullptr) return Status::Error("class priors: null output");
  const std::string source = "class priors file '" + path + "'";
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) {
    return Status::Error(source + ": not found or not a regular file");
  }
  // The pipeline cannot use io's readFile (io builds on it): the type above and the size here
  // bound the read (the package's file is 6 kB).
  constexpr std::uintmax_t kMaxPriorsFileBytes = std::uintmax_t{16} << 20;
  const std::uintmax_t size_bytes = std::filesystem::file_size(path, error);
  if (error || size_bytes > kMaxPriorsFileBytes) {
    return Status::Error(source + ": " +
                         (error ? error.message()
                                : std::to_string(size_bytes) + " bytes, more than the limit of " +
                                      std::to_string(kMaxPriorsFileBytes)));
  }
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  if (!in || !(text << in.rdbuf() || in.peek() == std::ifstream::traits_type::eof())) {
    return Status::Error(source + ": cannot be read");
  }
  ClassPriors parsed;
  const Status status = parseText(text.str(), &parsed);
  if (!status) return Status::Error(source + ": " + status.message());
  *priors = std::move(parsed);
  return Status::Ok();
}

const ClassPrior* ClassPriors::find(const std::string& class_name) const {
  auto it = priors_.find(class_name);
  if (it == priors_.end()) {
    // Darknet spellings ("diningtable") find the prior of their COCO class.
    const std::string canonical = canonicalCocoName(class_name);
    if (!canonical.empty() && canonical != class_name) it = priors_.find(canonical);
  }
  return it == priors_.end() ? nullptr : &it->second;
}

double ClassPriors::fusionDistance(const std::string& class_name) const {
  const ClassPrior* prior = find(class_name);
  return prior != nullptr ? prior->fusion_distance_m : default_fusion_distance_m;
}

}  // namespace mvod
