// Evaluation against ground truth (Sec. 4.1): per-class AP of object segmentation by the 3D IoU of
// voxelised point sets (Tables 1 and 2), and oriented-box mAP@0.25 / mAP@0.5.
//
// Ground truth (GroundTruthObject) and its loaders are datasets/ground_truth.h.
#pragma once

#include <string>
#include <vector>

#include "multiview_object_detection/datasets/ground_truth.h"
#include "multiview_object_detection/pipeline/map/object_database.h"
#include "multiview_object_detection/pipeline/types/common.h"
#include "multiview_object_detection/pipeline/types/oriented_box.h"

namespace mvod {

// One predicted object as the evaluation sees it.
struct EvaluatedPrediction {
  int id = 0;
  // The map's own class name, as every other output shows it ("suitcase"); the evaluation compares
  // canonicalClassName()s ("bag").
  std::string class_name;
  double probability = 0.0;
  OrientedBox box;
  // May be empty: the prediction then segments the ground-truth points (all classes) inside its
  // box, grown by surface_spacing_m.
  PointCloud points_W;
};

struct EvaluationOptions {
  double voxel_size_m = 0.05;       // voxel of the segmentation IoU
  double segmentation_iou = 0.5;    // match threshold of the segmentation AP (Sec. 4.1)
  double surface_spacing_m = 0.01;  // surface samples of GT without points; box margin
  Eigen::Vector3d up_W = Eigen::Vector3d::UnitZ();  // world "up" (z for synthetic, y for SceneNN)
};

struct ClassEvaluation {
  std::string class_name;
  int num_ground_truth = 0;
  int num_predictions = 0;
  // NaN when the class has no ground truth (AP undefined; such classes are left out of the means).
  double ap_segmentation = 0.0;
  double ap_box_25 = 0.0;
  double ap_box_50 = 0.0;
};

struct EvaluationResult {
  std::vector<ClassEvaluation> classes;  // sorted by name: every class in the GT or the predictions
  // Means over the classes present in the ground truth; NaN when the ground truth is empty.
  double map_segmentation = 0.0;
  double map_box_25 = 0.0;
  double map_box_50 = 0.0;
};

// ---- Pure metric functions ----

// PASCAL VOC all-point interpolated AP: `true_positive` is the ranked list (highest confidence
// first); precision is made monotone from the right and integrated over every recall step. 0 when
// num_gt is 0 or the list has no true positive.
double vocAveragePrecision(const std::vector<bool>& true_positive, int num_ground_truth);

// IoU of the voxel sets occupied by two clouds (grid anchored at the origin, non-finite points
// dropped): |shared voxels| / |union|. 0 when both are empty or voxel_size_m <= 0.
double voxelIoU(const PointCloud& a, const PointCloud& b, double voxel_size_m);

// Volume IoU of two gravity-aligned boxes (gravityAlignedIntersectionVolume). 0 for empty boxes.
double orientedBoxIoU(const OrientedBox& a, const OrientedBox& b, const Eigen::Vector3d& up_W);

// Greedy matching of ranked predictions (row order = rank) to ground truth: each prediction takes
// the unmatched ground truth of highest IoU, a true positive when that IoU >= threshold. A second
// prediction of an already matched object is a false positive. iou[p][g].
std::vector<bool> matchRankedPredictions(const std::vector<std::vector<double>>& iou,
                                         double threshold);

EvaluationResult evaluate(const std::vector<GroundTruthObject>& ground_truth,
                          const std::vector<EvaluatedPrediction>& predictions,
                          const EvaluationOptions& options);

// Several scenes pooled into one evaluation, as PASCAL VOC pools images: a class's predictions are
// ranked together across scenes, each can match only its own scene's ground truth, and the ground
// truth counts add up. (Scene k is moved by k * 1000 m along a horizontal axis, so no two scenes
// overlap; every scene must use options.up_W.)
struct EvaluationScene {
  std::vector<GroundTruthObject> ground_truth;
  std::vector<EvaluatedPrediction> predictions;
};
EvaluationResult evaluateScenes(std::vector<EvaluationScene> scenes,
                                const EvaluationOptions& options);

// Markdown table (AP in %, one decimal; "-" where undefined) and CSV (fractions; empty where
// undefined): class, #GT, #pred, AP seg, AP box@0.25, AP box@0.5, and a mean row.
std::string evaluationToMarkdown(const EvaluationResult& result);
std::string evaluationToCsv(const EvaluationResult& result);

// ---- Predictions (errors name the file) ----

// objects.json -> predictions. Points, the paper's "segmented object points": the LCCP segment
// stored in the file ("segment", written with include_clouds; else its "points", the fused cloud),
// or else, when clouds_dir is not empty, object_<id>_<class>_segment.ply (else _fused.ply) written
// by offline_detection --save-clouds; otherwise empty (the box segments the ground truth, see
// EvaluatedPrediction). *num_with_clouds (optional) counts predictions that got a cloud.
Status loadPredictions(const std::string& objects_json_path, const std::string& clouds_dir,
                       std::vector<EvaluatedPrediction>* predictions, int* num_with_clouds);
// Points: segment_W, or points_W where the segment is empty.
std::vector<EvaluatedPrediction> predictionsFromObjects(const std::vector<MapObject>& objects);
// "object_<id>_<class>", in the class every character but letters, digits, '-' and '_' as '_':
// the stem of the cloud files offline_detection --save-clouds writes and loadPredictions reads.
std::string objectCloudFileStem(int id, const std::string& class_name);

}  // namespace mvod
