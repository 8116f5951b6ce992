#include "multiview_object_detection/evaluation/evaluation.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "multiview_object_detection/datasets/class_names.h"
#include "multiview_object_detection/datasets/ground_truth_geometry.h"
#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/io/map_folder.h"
#include "multiview_object_detection/io/ply_reader.h"
#include "multiview_object_detection/pipeline/stages/box_estimator.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;
using VoxelKey = std::array<int64_t, 3>;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

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

}  // namespace

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
    prediction.class_name = object.class_name;
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
  // objects.json of offline_detection, or a map the node saved (a .mvmap folder).
  std::vector<MapObject> objects;
  MapSummary summary;
  Status status = loadMap(objects_json_path, Links::kFollow, &objects, &summary, nullptr);
  if (!status) {
    return Status::Error(status.message().rfind(objects_json_path, 0) == 0
                             ? status.message()
                             : objects_json_path + ": " + status.message());
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
            fs::path(clouds_dir) / (objectCloudFileStem(object.id, object.class_name) + suffix);
        std::error_code error;
        if (!fs::is_regular_file(cloud_path, error)) continue;
        if (!(status = readPlyVertices(cloud_path.string(), &prediction.points_W, nullptr))) {
          return status;
        }
        // offline_detection writes the clouds in the frame of its objects.json (its objects are
        // already back in the world frame: objectsFromJson).
        if (summary.objects_in_gravity_frame) {
          prediction.points_W = transformCloud(prediction.points_W, summary.T_W_O);
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

std::string objectCloudFileStem(int id, const std::string& class_name) {
  std::string safe = class_name;
  for (char& c : safe) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
  }
  return "object_" + std::to_string(id) + "_" + safe;
}

}  // namespace mvod
