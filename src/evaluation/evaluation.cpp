#include "multiview_object_detection/evaluation/evaluation.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <numeric>
#include <set>
#include <sstream>

#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/pipeline/stages/box_estimator.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;
using VoxelKey = std::array<int64_t, 3>;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string lowerTrim(const std::string& name) {
  size_t begin = 0;
  size_t end = name.size();
  while (begin < end && std::isspace(static_cast<unsigned char>(name[begin]))) ++begin;
  while (end > begin && std::isspace(static_cast<unsigned char>(name[end - 1]))) --end;
  std::string out = name.substr(begin, end - begin);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

// Sorted, unique occupied voxels of a cloud.
std::vector<VoxelKey> voxelise(const PointCloud& points, double voxel_size_m) {
  std::vector<VoxelKey> keys;
  if (!(voxel_size_m > 0.0) || !std::isfinite(voxel_size_m)) return keys;
  keys.reserve(points.size());
  constexpr double kLimit = 1e15;  // keeps the int64 conversion defined
  for (const Eigen::Vector3f& p : points) {
    if (!p.allFinite()) continue;
    VoxelKey key;
    bool ok = true;
    for (int i = 0; i < 3; ++i) {
      const double v = std::floor(static_cast<double>(p[i]) / voxel_size_m);
      if (!(std::abs(v) < kLimit)) ok = false;
      key[i] = ok ? static_cast<int64_t>(v) : 0;
    }
    if (ok) keys.push_back(key);
  }
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  return keys;
}

double voxelSetIoU(const std::vector<VoxelKey>& a, const std::vector<VoxelKey>& b) {
  if (a.empty() && b.empty()) return 0.0;
  size_t shared = 0;
  auto ia = a.begin();
  auto ib = b.begin();
  while (ia != a.end() && ib != b.end()) {
    if (*ia < *ib) {
      ++ia;
    } else if (*ib < *ia) {
      ++ib;
    } else {
      ++shared;
      ++ia;
      ++ib;
    }
  }
  const size_t union_size = a.size() + b.size() - shared;
  return static_cast<double>(shared) / static_cast<double>(union_size);
}

std::string formatPercent(double value) {
  if (!std::isfinite(value)) return "-";
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f", 100.0 * value);
  return text;
}

std::string formatFraction(double value) {
  if (!std::isfinite(value)) return "";
  char text[32];
  std::snprintf(text, sizeof(text), "%.4f", value);
  return text;
}

// ---- PLY ----

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

bool plyTypeFromName(const std::string& name, PlyType* type) {
  static const std::map<std::string, PlyType> kTypes = {
      {"char", PlyType::kInt8},      {"int8", PlyType::kInt8},       {"uchar", PlyType::kUint8},
      {"uint8", PlyType::kUint8},    {"short", PlyType::kInt16},     {"int16", PlyType::kInt16},
      {"ushort", PlyType::kUint16},  {"uint16", PlyType::kUint16},   {"int", PlyType::kInt32},
      {"int32", PlyType::kInt32},    {"uint", PlyType::kUint32},     {"uint32", PlyType::kUint32},
      {"float", PlyType::kFloat32},  {"float32", PlyType::kFloat32}, {"double", PlyType::kFloat64},
      {"float64", PlyType::kFloat64}};
  const auto it = kTypes.find(name);
  if (it == kTypes.end()) return false;
  *type = it->second;
  return true;
}

size_t plyTypeSize(PlyType type) {
  switch (type) {
    case PlyType::kInt8:
    case PlyType::kUint8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUint16:
      return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32:
      return 4;
    case PlyType::kFloat64:
      return 8;
  }
  return 1;
}

template <typename T>
double readAs(const char* data) {
  T value;
  std::memcpy(&value, data, sizeof(T));
  return static_cast<double>(value);
}

// Little-endian host assumed (x86 / ARM); checked once in readPlyVertices.
double readBinaryScalar(PlyType type, const char* data) {
  switch (type) {
    case PlyType::kInt8:
      return readAs<int8_t>(data);
    case PlyType::kUint8:
      return readAs<uint8_t>(data);
    case PlyType::kInt16:
      return readAs<int16_t>(data);
    case PlyType::kUint16:
      return readAs<uint16_t>(data);
    case PlyType::kInt32:
      return readAs<int32_t>(data);
    case PlyType::kUint32:
      return readAs<uint32_t>(data);
    case PlyType::kFloat32:
      return readAs<float>(data);
    case PlyType::kFloat64:
      return readAs<double>(data);
  }
  return 0.0;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kFloat32;
  bool is_list = false;
  PlyType count_type = PlyType::kUint8;
};

struct PlyElement {
  std::string name;
  size_t count = 0;
  std::vector<PlyProperty> properties;
};

// Reads scalars one by one from the body, ASCII or binary, with bounds checks.
class PlyReader {
 public:
  PlyReader(const std::string& body, bool binary) : body_(body), binary_(binary) {}
  bool next(PlyType type, double* value) {
    if (binary_) {
      const size_t size = plyTypeSize(type);
      if (pos_ + size > body_.size()) return false;
      *value = readBinaryScalar(type, body_.data() + pos_);
      pos_ += size;
      return true;
    }
    while (pos_ < body_.size() && std::isspace(static_cast<unsigned char>(body_[pos_]))) ++pos_;
    if (pos_ >= body_.size()) return false;
    const char* start = body_.c_str() + pos_;
    char* end = nullptr;
    const double v = std::strtod(start, &end);
    if (end == start) return false;
    pos_ += static_cast<size_t>(end - start);
    *value = v;
    return true;
  }
  size_t remaining() const { return body_.size() - pos_; }

 private:
  const std::string& body_;
  bool binary_;
  size_t pos_ = 0;
};

Status plyError(const std::string& path, const std::string& what) {
  return Status::Error(path + ": " + what);
}

// ---- XML (just the <label .../> elements of a SceneNN annotation) ----

std::string decodeXmlEntities(const std::string& text) {
  std::string out;
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '&') {
      static const std::pair<const char*, char> kEntities[] = {
          {"&amp;", '&'}, {"&lt;", '<'}, {"&gt;", '>'}, {"&quot;", '"'}, {"&apos;", '\''}};
      bool replaced = false;
      for (const auto& entity : kEntities) {
        const size_t length = std::strlen(entity.first);
        if (text.compare(i, length, entity.first) == 0) {
          out += entity.second;
          i += length - 1;
          replaced = true;
          break;
        }
      }
      if (replaced) continue;
    }
    out += text[i];
  }
  return out;
}

// Attributes of the element whose name ends at `pos`; `end` receives the index after '>'.
bool parseAttributes(const std::string& text, size_t pos, std::map<std::string, std::string>* out,
                     size_t* end) {
  while (true) {
    while (pos < text.size() && std::isspace(static_cast<unsigned char>(text[pos]))) ++pos;
    if (pos >= text.size()) return false;
    if (text[pos] == '>') {
      *end = pos + 1;
      return true;
    }
    if (text[pos] == '/') {
      if (pos + 1 < text.size() && text[pos + 1] == '>') {
        *end = pos + 2;
        return true;
      }
      return false;
    }
    const size_t name_begin = pos;
    while (pos < text.size() && text[pos] != '=' && text[pos] != '>' &&
           !std::isspace(static_cast<unsigned char>(text[pos]))) {
      ++pos;
    }
    const std::string name = text.substr(name_begin, pos - name_begin);
    while (pos < text.size() && std::isspace(static_cast<unsigned char>(text[pos]))) ++pos;
    if (name.empty() || pos >= text.size() || text[pos] != '=') return false;
    ++pos;
    while (pos < text.size() && std::isspace(static_cast<unsigned char>(text[pos]))) ++pos;
    if (pos >= text.size() || (text[pos] != '"' && text[pos] != '\'')) return false;
    const char quote = text[pos++];
    const size_t close = text.find(quote, pos);
    if (close == std::string::npos) return false;
    (*out)[name] = decodeXmlEntities(text.substr(pos, close - pos));
    pos = close + 1;
  }
}

// Whitespace-separated finite numbers, exactly `count` of them.
bool parseNumbers(const std::string& text, size_t count, std::vector<double>* out) {
  std::istringstream in(text);
  std::vector<double> values;
  std::string token;
  while (in >> token) {
    char* end = nullptr;
    const double v = std::strtod(token.c_str(), &end);
    if (*end != '\0' || !std::isfinite(v)) return false;
    values.push_back(v);
  }
  if (values.size() != count) return false;
  *out = std::move(values);
  return true;
}

std::string fileSafe(std::string name) {
  for (char& c : name) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
  }
  return name;
}

}  // namespace

// ---- Classes ----

std::string canonicalClassName(const std::string& name) {
  static const std::map<std::string, std::string> kSynonyms = {
      {"sofa", "couch"},
      {"table", "dining table"},
      {"diningtable", "dining table"},
      {"dining_table", "dining table"},
      {"television", "tv"},
      {"tvmonitor", "tv"},
      {"monitor", "tv"},
      {"books", "book"},
      {"fridge", "refrigerator"},
      {"refridgerator", "refrigerator"},  // NYU40's spelling
      {"backpack", "bag"},
      {"handbag", "bag"},
      {"suitcase", "bag"}};
  const std::string key = lowerTrim(name);
  const auto it = kSynonyms.find(key);
  return it == kSynonyms.end() ? key : it->second;
}

std::string sceneNNClassName(const std::string& label_text) {
  // The nine classes COCO and NYU share (the paper's Table 1). Desk is its own NYU class: left out.
  static const std::set<std::string> kEvaluated = {
      "bed", "chair", "couch", "dining table", "book", "refrigerator", "tv", "toilet", "bag"};
  std::string key = lowerTrim(label_text);
  // SceneNN instance texts sometimes carry a number ("chair2").
  while (!key.empty() && std::isdigit(static_cast<unsigned char>(key.back()))) key.pop_back();
  if (key == "coffee table") key = "table";
  const std::string name = canonicalClassName(key);
  return kEvaluated.count(name) ? name : std::string();
}

// ---- Metrics ----

double vocAveragePrecision(const std::vector<bool>& true_positive, int num_ground_truth) {
  if (num_ground_truth <= 0 || true_positive.empty()) return 0.0;
  const size_t n = true_positive.size();
  std::vector<double> recall(n + 2, 0.0);
  std::vector<double> precision(n + 2, 0.0);
  double tp = 0.0;
  double fp = 0.0;
  for (size_t i = 0; i < n; ++i) {
    (true_positive[i] ? tp : fp) += 1.0;
    recall[i + 1] = tp / num_ground_truth;
    precision[i + 1] = tp / (tp + fp);
  }
  recall[n + 1] = 1.0;
  precision[n + 1] = 0.0;
  // Precision envelope: the best precision at this recall or any higher one.
  for (size_t i = n + 1; i-- > 0;) precision[i] = std::max(precision[i], precision[i + 1]);
  double ap = 0.0;
  for (size_t i = 0; i + 1 < recall.size(); ++i) {
    if (recall[i + 1] != recall[i]) ap += (recall[i + 1] - recall[i]) * precision[i + 1];
  }
  return ap;
}

double voxelIoU(const PointCloud& a, const PointCloud& b, double voxel_size_m) {
  return voxelSetIoU(voxelise(a, voxel_size_m), voxelise(b, voxel_size_m));
}

double orientedBoxIoU(const OrientedBox& a, const OrientedBox& b, const Eigen::Vector3d& up_W) {
  const double va = a.volume();
  const double vb = b.volume();
  if (!(va > 0.0) || !(vb > 0.0) || !std::isfinite(va) || !std::isfinite(vb)) return 0.0;
  const double intersection = gravityAlignedIntersectionVolume(a, b, up_W);
  if (!(intersection > 0.0)) return 0.0;
  return std::min(1.0, intersection / (va + vb - intersection));
}

std::vector<bool> matchRankedPredictions(const std::vector<std::vector<double>>& iou,
                                         double threshold) {
  std::vector<bool> true_positive(iou.size(), false);
  std::vector<bool> matched;
  for (size_t p = 0; p < iou.size(); ++p) {
    if (matched.size() < iou[p].size()) matched.resize(iou[p].size(), false);
    int best = -1;
    double best_iou = -1.0;
    for (size_t g = 0; g < iou[p].size(); ++g) {
      const double value = std::isfinite(iou[p][g]) ? iou[p][g] : 0.0;
      if (!matched[g] && value > best_iou) {
        best = static_cast<int>(g);
        best_iou = value;
      }
    }
    if (best >= 0 && best_iou >= threshold) {
      matched[best] = true;
      true_positive[p] = true;
    }
  }
  return true_positive;
}

PointCloud sampleBoxSurface(const OrientedBox& box, double spacing_m, const Eigen::Vector3d& up_W) {
  PointCloud points;
  if (!(spacing_m > 0.0) || !std::isfinite(spacing_m) || !box.center_m.allFinite() ||
      !box.size_m.allFinite() || !box.rotation.allFinite() || (box.size_m.array() < 0.0).any()) {
    return points;
  }
  const Eigen::Vector3d up =
      up_W.allFinite() && up_W.norm() > 1e-9 ? up_W.normalized() : Eigen::Vector3d::UnitZ();
  constexpr int kMaxSteps = 2000;  // bounds memory for absurd boxes
  auto steps = [&](double extent) {
    return std::clamp(static_cast<int>(std::ceil(extent / spacing_m)), 1, kMaxSteps);
  };
  for (int axis = 0; axis < 3; ++axis) {
    for (const double sign : {-1.0, 1.0}) {
      const Eigen::Vector3d normal = sign * box.rotation.col(axis);
      if (normal.dot(up) < -0.9) continue;  // the bottom face
      const int j = (axis + 1) % 3;
      const int k = (axis + 2) % 3;
      const int nj = steps(box.size_m[j]);
      const int nk = steps(box.size_m[k]);
      for (int a = 0; a <= nj; ++a) {
        for (int b = 0; b <= nk; ++b) {
          Eigen::Vector3d local;
          local[axis] = 0.5 * sign * box.size_m[axis];
          local[j] = box.size_m[j] * (static_cast<double>(a) / nj - 0.5);
          local[k] = box.size_m[k] * (static_cast<double>(b) / nk - 0.5);
          points.push_back((box.center_m + box.rotation * local).cast<float>());
        }
      }
    }
  }
  return points;
}

OrientedBox fitGravityAlignedBox(const PointCloud& points_W, const Eigen::Vector3d& up_W) {
  OrientedBox box;
  const GravityFrame frame(up_W.allFinite() && up_W.norm() > 1e-9 ? Eigen::Vector3d(-up_W)
                                                                  : Eigen::Vector3d(0, 0, -1));
  BoxEstimator::Config manhattan;
  manhattan.extent_trim_fraction = 0.0;      // ground truth: the whole surface
  manhattan.footprint_yaw_area_ratio = 0.0;  // (the ground truth of earlier releases)
  manhattan.outline_cell_m = 0.0;
  manhattan.normal_estimation = "radius";  // per point, as for the ground truth before
  if (points_W.size() >= 200 && BoxEstimator(manhattan).estimate(points_W, frame, &box).ok()) {
    return box;
  }
  box = OrientedBox();
  std::vector<Eigen::Vector2d> footprint;
  double low = std::numeric_limits<double>::infinity();
  double high = -std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3f& pf : points_W) {
    if (!pf.allFinite()) continue;
    const Eigen::Vector3d p = pf.cast<double>();
    footprint.emplace_back(p.dot(frame.x_h), p.dot(frame.y_h));
    low = std::min(low, p.dot(frame.up));
    high = std::max(high, p.dot(frame.up));
  }
  if (footprint.empty()) return box;
  const Rectangle2d rectangle = minimumAreaRectangle(footprint);
  box.center_m = rectangle.center.x() * frame.x_h + rectangle.center.y() * frame.y_h +
                 0.5 * (low + high) * frame.up;
  box.size_m = Eigen::Vector3d(rectangle.size.x(), rectangle.size.y(), high - low);
  box.rotation = frame.rotationFromYaw(rectangle.yaw_rad);
  return box;
}

EvaluationResult evaluate(const std::vector<GroundTruthObject>& ground_truth,
                          const std::vector<EvaluatedPrediction>& predictions,
                          const EvaluationOptions& options) {
  struct Item {
    const OrientedBox* box;
    double probability;
    std::vector<VoxelKey> voxels;
  };
  std::map<std::string, std::vector<Item>> gt_by_class;
  std::map<std::string, std::vector<Item>> pred_by_class;
  // Ground truth without points stands for its box's visible surface (Sec. 4.1 compares surface
  // points, and that is what a depth camera sees of a box).
  std::vector<PointCloud> gt_points(ground_truth.size());
  for (size_t i = 0; i < ground_truth.size(); ++i) {
    gt_points[i] =
        ground_truth[i].points_W.empty()
            ? sampleBoxSurface(ground_truth[i].box, options.surface_spacing_m, options.up_W)
            : ground_truth[i].points_W;
  }
  for (size_t i = 0; i < ground_truth.size(); ++i) {
    const std::string name = canonicalClassName(ground_truth[i].class_name);
    if (name.empty()) continue;
    gt_by_class[name].push_back(
        {&ground_truth[i].box, 1.0, voxelise(gt_points[i], options.voxel_size_m)});
  }
  for (const EvaluatedPrediction& object : predictions) {
    const std::string name = canonicalClassName(object.class_name);
    if (name.empty()) continue;
    const PointCloud* points = &object.points_W;
    PointCloud inside;
    if (object.points_W.empty()) {
      // No cloud: the box segments the ground-truth points it contains (every class). A box
      // surface against a surface would turn a few centimetres of box error into a lost match.
      for (const PointCloud& cloud : gt_points) {
        for (const Eigen::Vector3f& p : cloud) {
          if (object.box.contains(p.cast<double>(), options.surface_spacing_m)) {
            inside.push_back(p);
          }
        }
      }
      points = &inside;
    }
    pred_by_class[name].push_back({&object.box,
                                   std::isfinite(object.probability) ? object.probability : 0.0,
                                   voxelise(*points, options.voxel_size_m)});
  }
  std::set<std::string> names;
  for (const auto& entry : gt_by_class) names.insert(entry.first);
  for (const auto& entry : pred_by_class) names.insert(entry.first);

  EvaluationResult result;
  double sums[3] = {0.0, 0.0, 0.0};
  int classes_with_gt = 0;
  static const std::vector<Item> kNone;
  for (const std::string& name : names) {
    const auto gt_it = gt_by_class.find(name);
    const auto pred_it = pred_by_class.find(name);
    const std::vector<Item>& gts = gt_it == gt_by_class.end() ? kNone : gt_it->second;
    std::vector<Item> preds = pred_it == pred_by_class.end() ? kNone : pred_it->second;
    // Ranked by probability; ties keep the file order.
    std::stable_sort(preds.begin(), preds.end(),
                     [](const Item& a, const Item& b) { return a.probability > b.probability; });
    std::vector<std::vector<double>> seg_iou(preds.size(), std::vector<double>(gts.size()));
    std::vector<std::vector<double>> box_iou(preds.size(), std::vector<double>(gts.size()));
    for (size_t p = 0; p < preds.size(); ++p) {
      for (size_t g = 0; g < gts.size(); ++g) {
        seg_iou[p][g] = voxelSetIoU(preds[p].voxels, gts[g].voxels);
        box_iou[p][g] = orientedBoxIoU(*preds[p].box, *gts[g].box, options.up_W);
      }
    }
    ClassEvaluation row;
    row.class_name = name;
    row.num_ground_truth = static_cast<int>(gts.size());
    row.num_predictions = static_cast<int>(preds.size());
    if (gts.empty()) {
      row.ap_segmentation = row.ap_box_25 = row.ap_box_50 = kNaN;
    } else {
      const int n = row.num_ground_truth;
      row.ap_segmentation =
          vocAveragePrecision(matchRankedPredictions(seg_iou, options.segmentation_iou), n);
      row.ap_box_25 = vocAveragePrecision(matchRankedPredictions(box_iou, 0.25), n);
      row.ap_box_50 = vocAveragePrecision(matchRankedPredictions(box_iou, 0.5), n);
      sums[0] += row.ap_segmentation;
      sums[1] += row.ap_box_25;
      sums[2] += row.ap_box_50;
      ++classes_with_gt;
    }
    result.classes.push_back(row);
  }
  result.map_segmentation = classes_with_gt ? sums[0] / classes_with_gt : kNaN;
  result.map_box_25 = classes_with_gt ? sums[1] / classes_with_gt : kNaN;
  result.map_box_50 = classes_with_gt ? sums[2] / classes_with_gt : kNaN;
  return result;
}

std::string evaluationToMarkdown(const EvaluationResult& result) {
  std::ostringstream out;
  out << "| Class | #GT | #Pred | AP seg (%) | AP box@0.25 (%) | AP box@0.5 (%) |\n"
      << "|---|--:|--:|--:|--:|--:|\n";
  int total_gt = 0;
  int total_pred = 0;
  for (const ClassEvaluation& row : result.classes) {
    out << "| " << row.class_name << " | " << row.num_ground_truth << " | " << row.num_predictions
        << " | " << formatPercent(row.ap_segmentation) << " | " << formatPercent(row.ap_box_25)
        << " | " << formatPercent(row.ap_box_50) << " |\n";
    total_gt += row.num_ground_truth;
    total_pred += row.num_predictions;
  }
  out << "| **mean** | " << total_gt << " | " << total_pred << " | "
      << formatPercent(result.map_segmentation) << " | " << formatPercent(result.map_box_25)
      << " | " << formatPercent(result.map_box_50) << " |\n";
  return out.str();
}

std::string evaluationToCsv(const EvaluationResult& result) {
  std::ostringstream out;
  out << "class,num_gt,num_pred,ap_seg,ap_box_25,ap_box_50\n";
  int total_gt = 0;
  int total_pred = 0;
  for (const ClassEvaluation& row : result.classes) {
    // Class names are COCO / NYU words: quote them anyway in case of a comma.
    std::string name = row.class_name;
    if (name.find_first_of(",\"") != std::string::npos) {
      std::string quoted = "\"";
      for (char c : name) quoted += (c == '"') ? std::string("\"\"") : std::string(1, c);
      name = quoted + "\"";
    }
    out << name << "," << row.num_ground_truth << "," << row.num_predictions << ","
        << formatFraction(row.ap_segmentation) << "," << formatFraction(row.ap_box_25) << ","
        << formatFraction(row.ap_box_50) << "\n";
    total_gt += row.num_ground_truth;
    total_pred += row.num_predictions;
  }
  out << "mean," << total_gt << "," << total_pred << "," << formatFraction(result.map_segmentation)
      << "," << formatFraction(result.map_box_25) << "," << formatFraction(result.map_box_50)
      << "\n";
  return out.str();
}

// ---- Loaders ----

Status readPlyVertices(const std::string& path, PointCloud* points, std::vector<int>* labels) {
  if (points == nullptr) return Status::Error(path + ": no output cloud");
  std::string content;
  Status status = readFile(path, &content);
  if (!status) return status;
  size_t pos = 0;
  auto nextLine = [&content, &pos](std::string* line) {
    if (pos >= content.size()) return false;
    size_t end = content.find('\n', pos);
    if (end == std::string::npos) end = content.size();
    *line = content.substr(pos, end - pos);
    if (!line->empty() && line->back() == '\r') line->pop_back();
    pos = end + 1;
    return true;
  };
  std::string line;
  if (!nextLine(&line) || line != "ply") return plyError(path, "not a PLY file (no 'ply' magic)");
  bool binary = false;
  bool have_format = false;
  bool have_end = false;
  std::vector<PlyElement> elements;
  while (nextLine(&line)) {
    std::istringstream in(line);
    std::string keyword;
    in >> keyword;
    if (keyword.empty() || keyword == "comment" || keyword == "obj_info") continue;
    if (keyword == "end_header") {
      have_end = true;
      break;
    }
    if (keyword == "format") {
      std::string format;
      in >> format;
      if (format == "ascii") {
        binary = false;
      } else if (format == "binary_little_endian") {
        binary = true;
      } else {
        return plyError(path, "unsupported PLY format '" + format + "'");
      }
      have_format = true;
    } else if (keyword == "element") {
      PlyElement element;
      long long count = -1;
      if (!(in >> element.name >> count) || count < 0) {
        return plyError(path, "bad element line '" + line + "'");
      }
      element.count = static_cast<size_t>(count);
      elements.push_back(element);
    } else if (keyword == "property") {
      if (elements.empty()) return plyError(path, "property before any element");
      PlyProperty property;
      std::string type;
      in >> type;
      if (type == "list") {
        std::string count_type, item_type;
        in >> count_type >> item_type >> property.name;
        property.is_list = true;
        if (!plyTypeFromName(count_type, &property.count_type) ||
            !plyTypeFromName(item_type, &property.type)) {
          return plyError(path, "bad property line '" + line + "'");
        }
      } else {
        in >> property.name;
        if (!plyTypeFromName(type, &property.type)) {
          return plyError(path, "unknown property type '" + type + "'");
        }
      }
      if (property.name.empty()) return plyError(path, "property without a name");
      elements.back().properties.push_back(property);
    } else {
      return plyError(path, "unexpected header line '" + line + "'");
    }
  }
  if (!have_format) return plyError(path, "no format line in the header");
  if (!have_end) return plyError(path, "no end_header");
  if (binary) {
    const uint16_t probe = 1;
    uint8_t first = 0;
    std::memcpy(&first, &probe, 1);
    if (first != 1) return plyError(path, "binary PLY needs a little-endian host");
  }
  const std::string body = content.substr(std::min(pos, content.size()));
  PlyReader reader(body, binary);
  for (const PlyElement& element : elements) {
    const bool is_vertex = element.name == "vertex";
    int ix = -1, iy = -1, iz = -1, il = -1;
    for (size_t i = 0; i < element.properties.size(); ++i) {
      const PlyProperty& property = element.properties[i];
      if (property.is_list) continue;
      if (property.name == "x") ix = static_cast<int>(i);
      if (property.name == "y") iy = static_cast<int>(i);
      if (property.name == "z") iz = static_cast<int>(i);
      if (property.name == "label") il = static_cast<int>(i);
    }
    if (is_vertex) {
      if (ix < 0 || iy < 0 || iz < 0) return plyError(path, "vertex element lacks x, y or z");
      if (labels != nullptr && il < 0) return plyError(path, "no vertex property 'label'");
      // Every vertex takes at least one byte (binary) or two (ascii): refuse absurd counts early.
      if (element.count > reader.remaining()) {
        return plyError(path, "truncated: " + std::to_string(element.count) + " vertices declared");
      }
    }
    PointCloud cloud;
    std::vector<int> vertex_labels;
    if (is_vertex) {
      cloud.reserve(element.count);
      if (labels != nullptr) vertex_labels.reserve(element.count);
    }
    std::vector<double> values(element.properties.size(), 0.0);
    for (size_t item = 0; item < element.count; ++item) {
      for (size_t i = 0; i < element.properties.size(); ++i) {
        const PlyProperty& property = element.properties[i];
        if (property.is_list) {
          double count = 0.0;
          if (!reader.next(property.count_type, &count) || !(count >= 0.0) ||
              count > static_cast<double>(reader.remaining())) {
            return plyError(path, "truncated or bad list in element '" + element.name + "'");
          }
          double ignored;
          for (size_t k = 0; k < static_cast<size_t>(count); ++k) {
            if (!reader.next(property.type, &ignored)) {
              return plyError(path, "truncated list in element '" + element.name + "'");
            }
          }
        } else if (!reader.next(property.type, &values[i])) {
          return plyError(path, "truncated: element '" + element.name + "' item " +
                                    std::to_string(item) + " of " + std::to_string(element.count));
        }
      }
      if (is_vertex) {
        cloud.emplace_back(static_cast<float>(values[ix]), static_cast<float>(values[iy]),
                           static_cast<float>(values[iz]));
        if (labels != nullptr) {
          const double label = values[il];
          if (!std::isfinite(label) || std::abs(label) > 2e9) {
            return plyError(path, "bad label at vertex " + std::to_string(item));
          }
          vertex_labels.push_back(static_cast<int>(label));
        }
      }
    }
    if (is_vertex) {
      *points = std::move(cloud);
      if (labels != nullptr) *labels = std::move(vertex_labels);
      return Status::Ok();  // what follows (faces) is not needed
    }
  }
  return plyError(path, "no vertex element");
}

Status readSceneNNXml(const std::string& path, std::vector<SceneNNLabel>* labels) {
  if (labels == nullptr) return Status::Error(path + ": no output");
  std::string text;
  Status status = readFile(path, &text);
  if (!status) return status;
  if (text.find("<annotation") == std::string::npos) {
    return Status::Error(path + ": no <annotation> element");
  }
  std::vector<SceneNNLabel> parsed;
  size_t pos = 0;
  while ((pos = text.find("<label", pos)) != std::string::npos) {
    const size_t after = pos + 6;
    if (after < text.size() && !std::isspace(static_cast<unsigned char>(text[after])) &&
        text[after] != '/' && text[after] != '>') {
      pos = after;  // e.g. <labels>
      continue;
    }
    std::map<std::string, std::string> attributes;
    size_t end = 0;
    const std::string where = path + ": <label> #" + std::to_string(parsed.size() + 1);
    if (!parseAttributes(text, after, &attributes, &end)) {
      return Status::Error(where + ": malformed attributes");
    }
    pos = end;
    SceneNNLabel label;
    const auto id = attributes.find("id");
    long id_value = 0;
    char* id_end = nullptr;
    if (id == attributes.end()) return Status::Error(where + ": missing id");
    id_value = std::strtol(id->second.c_str(), &id_end, 10);
    if (id->second.empty() || *id_end != '\0' || id_value < 0 || id_value > 2000000000L) {
      return Status::Error(where + ": bad id '" + id->second + "'");
    }
    label.id = static_cast<int>(id_value);
    const auto text_it = attributes.find("text");
    if (text_it == attributes.end()) return Status::Error(where + ": missing text");
    label.text = text_it->second;
    const auto nyu = attributes.find("nyu_class");
    if (nyu != attributes.end()) label.nyu_class = nyu->second;
    const auto aabb = attributes.find("aabbox");
    std::vector<double> numbers;
    if (aabb == attributes.end()) return Status::Error(where + ": missing aabbox");
    if (!parseNumbers(aabb->second, 6, &numbers)) {
      return Status::Error(where + ": aabbox needs 6 numbers");
    }
    label.aabb_min = Eigen::Vector3d(numbers[0], numbers[1], numbers[2]);
    label.aabb_max = Eigen::Vector3d(numbers[3], numbers[4], numbers[5]);
    const auto obb = attributes.find("obbox");
    if (obb != attributes.end()) {
      if (!parseNumbers(obb->second, 10, &numbers)) {
        return Status::Error(where + ": obbox needs 10 numbers (cx cy cz dx dy dz qx qy qz qw)");
      }
      label.has_obbox = true;
      for (int i = 0; i < 10; ++i) label.obbox[i] = numbers[i];
    }
    parsed.push_back(label);
  }
  *labels = std::move(parsed);
  return Status::Ok();
}

Status loadSyntheticGroundTruth(const std::string& path, double spacing_m,
                                const Eigen::Vector3d& up_W,
                                std::vector<GroundTruthObject>* objects) {
  if (objects == nullptr) return Status::Error(path + ": no output");
  std::string text;
  Status status = readFile(path, &text);
  if (!status) return status;
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    return Status::Error(path + ": not valid JSON: " + e.what());
  }
  if (!doc.is_object() || !doc.contains("objects") || !doc["objects"].is_array()) {
    return Status::Error(path + ": expected {\"objects\": [...]}");
  }
  auto readVector = [](const nlohmann::json& value, Eigen::Vector3d* out) {
    if (!value.is_array() || value.size() != 3) return false;
    for (int i = 0; i < 3; ++i) {
      if (!value[i].is_number()) return false;
      (*out)[i] = value[i].get<double>();
    }
    return out->allFinite();
  };
  std::vector<GroundTruthObject> parsed;
  const nlohmann::json& list = doc["objects"];
  for (size_t i = 0; i < list.size(); ++i) {
    const nlohmann::json& entry = list[i];
    const std::string where = path + ": objects[" + std::to_string(i) + "]";
    if (!entry.is_object()) return Status::Error(where + ": expected an object");
    if (!entry.contains("class_name") || !entry["class_name"].is_string()) {
      return Status::Error(where + ".class_name: missing or not a string");
    }
    GroundTruthObject object;
    object.class_name = canonicalClassName(entry["class_name"].get<std::string>());
    if (!entry.contains("center") || !readVector(entry["center"], &object.box.center_m)) {
      return Status::Error(where + ".center: expected [x, y, z]");
    }
    if (!entry.contains("size") || !readVector(entry["size"], &object.box.size_m) ||
        (object.box.size_m.array() < 0.0).any()) {
      return Status::Error(where + ".size: expected [x, y, z] >= 0");
    }
    if (entry.contains("rotation")) {
      const nlohmann::json& rotation = entry["rotation"];
      if (!rotation.is_array() || rotation.size() != 3) {
        return Status::Error(where + ".rotation: expected a 3x3 array of rows");
      }
      for (int r = 0; r < 3; ++r) {
        Eigen::Vector3d row;
        if (!readVector(rotation[r], &row)) {
          return Status::Error(where + ".rotation: expected a 3x3 array of rows");
        }
        object.box.rotation.row(r) = row.transpose();
      }
      const Eigen::Matrix3d& R = object.box.rotation;
      if (!(R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), 1e-3) ||
          std::abs(R.determinant() - 1.0) > 1e-3) {
        return Status::Error(where + ".rotation: not a rotation");
      }
    } else if (entry.contains("yaw") && entry["yaw"].is_number()) {
      object.box.rotation = GravityFrame(-up_W).rotationFromYaw(entry["yaw"].get<double>());
    } else {
      return Status::Error(where + ": needs rotation or yaw");
    }
    // Unlabelled clutter (empty class) is scenery, not ground truth.
    if (object.class_name.empty()) continue;
    if (entry.contains("points")) {
      // Optional observed ground-truth surface (e.g. noise-free depth of the object's pixels).
      const nlohmann::json& points = entry["points"];
      if (!points.is_array()) return Status::Error(where + ".points: expected [[x, y, z], ...]");
      for (size_t k = 0; k < points.size(); ++k) {
        Eigen::Vector3d p;
        if (!readVector(points[k], &p)) {
          return Status::Error(where + ".points[" + std::to_string(k) + "]: expected [x, y, z]");
        }
        object.points_W.push_back(p.cast<float>());
      }
    }
    if (object.points_W.empty()) object.points_W = sampleBoxSurface(object.box, spacing_m, up_W);
    parsed.push_back(std::move(object));
  }
  *objects = std::move(parsed);
  return Status::Ok();
}

Status loadSceneNNGroundTruth(const std::string& path, const Eigen::Vector3d& up_W,
                              std::vector<GroundTruthObject>* objects) {
  if (objects == nullptr) return Status::Error(path + ": no output");
  std::error_code error;
  fs::path ply_path;
  fs::path xml_path;
  if (fs::is_directory(path, error)) {
    fs::path dir = fs::path(path).lexically_normal();
    if (dir.filename().empty()) dir = dir.parent_path();
    const std::string id = dir.filename().string();
    ply_path = dir / (id + ".ply");
    xml_path = dir / (id + ".xml");
  } else {
    ply_path = path;
    xml_path = fs::path(path).replace_extension(".xml");
  }
  if (!fs::is_regular_file(ply_path, error)) {
    return Status::Error(path + ": no SceneNN mesh " + ply_path.string());
  }
  if (!fs::is_regular_file(xml_path, error)) {
    return Status::Error(path + ": no SceneNN annotation " + xml_path.string());
  }
  std::vector<SceneNNLabel> labels;
  Status status = readSceneNNXml(xml_path.string(), &labels);
  if (!status) return status;
  PointCloud vertices;
  std::vector<int> vertex_labels;
  if (!(status = readPlyVertices(ply_path.string(), &vertices, &vertex_labels))) return status;
  std::map<int, PointCloud> by_label;
  for (size_t i = 0; i < vertices.size(); ++i) {
    if (vertex_labels[i] != 0) by_label[vertex_labels[i]].push_back(vertices[i]);
  }
  std::vector<GroundTruthObject> parsed;
  for (const SceneNNLabel& label : labels) {
    std::string name = sceneNNClassName(label.nyu_class);
    if (name.empty()) name = sceneNNClassName(label.text);
    if (name.empty()) continue;
    const auto it = by_label.find(label.id);
    if (it == by_label.end() || it->second.empty()) continue;
    GroundTruthObject object;
    object.class_name = name;
    object.points_W = it->second;
    object.box = fitGravityAlignedBox(object.points_W, up_W);
    parsed.push_back(std::move(object));
  }
  *objects = std::move(parsed);
  return Status::Ok();
}

EvaluationResult evaluateScenes(std::vector<EvaluationScene> scenes,
                                const EvaluationOptions& options) {
  constexpr double kSceneSpacingM = 1000.0;
  const Eigen::Vector3d up =
      options.up_W.norm() > 1e-9 ? options.up_W.normalized() : Eigen::Vector3d::UnitZ();
  Eigen::Index axis = 0;
  up.cwiseAbs().minCoeff(&axis);
  const Eigen::Vector3d across =
      (Eigen::Vector3d::Unit(axis) - Eigen::Vector3d::Unit(axis).dot(up) * up).normalized();
  std::vector<GroundTruthObject> ground_truth;
  std::vector<EvaluatedPrediction> predictions;
  for (size_t k = 0; k < scenes.size(); ++k) {
    const Eigen::Vector3d shift = static_cast<double>(k) * kSceneSpacingM * across;
    const Eigen::Vector3f shift_f = shift.cast<float>();
    for (GroundTruthObject& object : scenes[k].ground_truth) {
      object.box.center_m += shift;
      for (Eigen::Vector3f& p : object.points_W) p += shift_f;
      ground_truth.push_back(std::move(object));
    }
    for (EvaluatedPrediction& object : scenes[k].predictions) {
      object.box.center_m += shift;
      for (Eigen::Vector3f& p : object.points_W) p += shift_f;
      predictions.push_back(std::move(object));
    }
  }
  return evaluate(ground_truth, predictions, options);
}

std::vector<EvaluatedPrediction> predictionsFromObjects(const std::vector<MapObject>& objects) {
  std::vector<EvaluatedPrediction> predictions;
  predictions.reserve(objects.size());
  for (const MapObject& object : objects) {
    EvaluatedPrediction prediction;
    prediction.id = object.id;
    prediction.class_name = canonicalClassName(object.class_name);
    prediction.probability = object.probability;
    prediction.box = object.box;
    // The paper scores "the segmented object points" (Sec. 4.1): the LCCP segment of the fused
    // cloud; the fused cloud only where no segment was stored.
    prediction.points_W = object.segment_W.empty() ? object.points_W : object.segment_W;
    predictions.push_back(std::move(prediction));
  }
  return predictions;
}

Status loadPredictions(const std::string& objects_json_path, const std::string& clouds_dir,
                       std::vector<EvaluatedPrediction>* predictions, int* num_with_clouds) {
  if (predictions == nullptr) return Status::Error(objects_json_path + ": no output");
  std::string text;
  Status status = readFile(objects_json_path, &text);
  if (!status) return status;
  std::vector<MapObject> objects;
  MapSummary summary;
  if (!(status = objectsFromJson(text, &objects, &summary))) {
    return Status::Error(objects_json_path + ": " + status.message());
  }
  std::vector<EvaluatedPrediction> parsed;
  int with_clouds = 0;
  for (const MapObject& object : objects) {
    std::vector<MapObject> one = {object};
    EvaluatedPrediction prediction = predictionsFromObjects(one).front();
    if (prediction.points_W.empty() && !clouds_dir.empty()) {
      // offline_detection --save-clouds names the files object_<id>_<class>_segment.ply (the
      // LCCP segment, scored) and ..._fused.ply (the fused cloud, the fallback).
      for (const char* suffix : {"_segment.ply", "_fused.ply"}) {
        const fs::path cloud_path =
            fs::path(clouds_dir) /
            ("object_" + std::to_string(object.id) + "_" + fileSafe(object.class_name) + suffix);
        std::error_code error;
        if (!fs::is_regular_file(cloud_path, error)) continue;
        if (!(status = readPlyVertices(cloud_path.string(), &prediction.points_W, nullptr))) {
          return status;
        }
        if (!prediction.points_W.empty()) break;
      }
    }
    if (!prediction.points_W.empty()) ++with_clouds;
    parsed.push_back(std::move(prediction));
  }
  *predictions = std::move(parsed);
  if (num_with_clouds != nullptr) *num_with_clouds = with_clouds;
  return Status::Ok();
}

}  // namespace mvod
