// Object by object against an annotation (the redkitchen's hand-checked boxes): which map object
// each annotated object became, how far off, and which map objects of the annotated classes match
// nothing. What a per-class AP hides.
#pragma once

#include <string>
#include <vector>

#include "multiview_object_detection/evaluation/evaluation.h"

namespace mvod {

struct AnnotatedObjectMatch {
  int annotation_index = 0;  // into the ground truth, in file order
  std::string class_name;
  int prediction_id = -1;  // the same-class map object of highest box IoU (-1: none)
  double box_iou = 0.0;    // 3D IoU of the two boxes
  // Horizontal distance between the box centres (m); NaN when the class has no prediction. Where
  // no box overlaps, the nearest same-class object's.
  double centre_distance_m = 0.0;
};

struct ObjectMatches {
  std::vector<AnnotatedObjectMatch> annotated;
  // Map objects of an annotated class whose box overlaps none of its class's annotations by
  // min_iou or more: false objects, or duplicates (a second object of a matched one is listed).
  std::vector<int> unmatched_prediction_ids;
};

// Each annotation takes its best same-class prediction by box IoU, greedily in descending IoU
// (one prediction per annotation). up_W: the world's up.
ObjectMatches matchObjects(const std::vector<GroundTruthObject>& ground_truth,
                           const std::vector<EvaluatedPrediction>& predictions,
                           const Eigen::Vector3d& up_W, double min_iou = 0.25);

// Markdown: one row per annotated object, then the unmatched objects with their class and centre.
std::string objectMatchesToMarkdown(const ObjectMatches& matches,
                                    const std::vector<EvaluatedPrediction>& predictions);

}  // namespace mvod
