#include "multiview_object_detection/evaluation/object_matches.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <tuple>

#include "multiview_object_detection/datasets/class_names.h"

namespace mvod {
namespace {

double horizontalDistance(const OrientedBox& a, const OrientedBox& b, const Eigen::Vector3d& up) {
  const Eigen::Vector3d d = a.center_m - b.center_m;
  return (d - up * up.dot(d)).norm();
}

}  // namespace

ObjectMatches matchObjects(const std::vector<GroundTruthObject>& ground_truth,
                           const std::vector<EvaluatedPrediction>& predictions,
                           const Eigen::Vector3d& up_W, double min_iou) {
  const Eigen::Vector3d up = up_W.normalized();
  ObjectMatches matches;
  // Every same-class pair with its IoU, best first: a greedy one-to-one assignment.
  std::vector<std::tuple<double, size_t, size_t>> pairs;
  std::set<std::string> annotated_classes;
  // The evaluation classes ("suitcase" and "bag" are one).
  std::vector<std::string> predicted(predictions.size());
  for (size_t p = 0; p < predictions.size(); ++p) {
    predicted[p] = canonicalClassName(predictions[p].class_name);
  }
  for (size_t g = 0; g < ground_truth.size(); ++g) {
    annotated_classes.insert(ground_truth[g].class_name);
    for (size_t p = 0; p < predictions.size(); ++p) {
      if (predicted[p] != ground_truth[g].class_name) continue;
      pairs.emplace_back(orientedBoxIoU(predictions[p].box, ground_truth[g].box, up), g, p);
    }
  }
  std::stable_sort(pairs.begin(), pairs.end(),
                   [](const auto& a, const auto& b) { return std::get<0>(a) > std::get<0>(b); });
  std::vector<int> taken_by(ground_truth.size(), -1);
  std::vector<char> used(predictions.size(), 0);
  for (const auto& [iou, g, p] : pairs) {
    if (!(iou > 0.0) || taken_by[g] >= 0 || used[p]) continue;
    taken_by[g] = static_cast<int>(p);
    used[p] = 1;
  }
  for (size_t g = 0; g < ground_truth.size(); ++g) {
    AnnotatedObjectMatch match;
    match.annotation_index = static_cast<int>(g);
    match.class_name = ground_truth[g].class_name;
    match.centre_distance_m = std::numeric_limits<double>::quiet_NaN();
    if (taken_by[g] >= 0) {
      const EvaluatedPrediction& p = predictions[taken_by[g]];
      match.prediction_id = p.id;
      match.box_iou = orientedBoxIoU(p.box, ground_truth[g].box, up);
      match.centre_distance_m = horizontalDistance(p.box, ground_truth[g].box, up);
    } else {
      for (size_t p = 0; p < predictions.size(); ++p) {
        if (predicted[p] != match.class_name) continue;
        const double d = horizontalDistance(predictions[p].box, ground_truth[g].box, up);
        if (!(d >= match.centre_distance_m)) match.centre_distance_m = d;
      }
    }
    matches.annotated.push_back(match);
  }
  for (size_t p = 0; p < predictions.size(); ++p) {
    if (!annotated_classes.count(predicted[p])) continue;
    double best = 0.0;
    for (size_t g = 0; g < ground_truth.size(); ++g) {
      if (ground_truth[g].class_name != predicted[p]) continue;
      if (taken_by[g] >= 0 && taken_by[g] != static_cast<int>(p)) continue;  // a duplicate
      best = std::max(best, orientedBoxIoU(predictions[p].box, ground_truth[g].box, up));
    }
    if (best < min_iou) matches.unmatched_prediction_ids.push_back(predictions[p].id);
  }
  return matches;
}

std::string objectMatchesToMarkdown(const ObjectMatches& matches,
                                    const std::vector<EvaluatedPrediction>& predictions) {
  std::string out =
      "| annotation | class | map object | box IoU | centre error (m) |\n"
      "|--:|---|--:|--:|--:|\n";
  char line[256];
  for (const AnnotatedObjectMatch& m : matches.annotated) {
    const std::string id = m.prediction_id >= 0 ? "#" + std::to_string(m.prediction_id) : "-";
    const std::string distance = std::isnan(m.centre_distance_m) ? "-" : [&] {
      char text[32];
      std::snprintf(text, sizeof(text), "%.3f%s", m.centre_distance_m,
                    m.prediction_id >= 0 ? "" : " (nearest)");
      return std::string(text);
    }();
    std::snprintf(line, sizeof(line), "| %d | %s | %s | %.2f | %s |\n", m.annotation_index,
                  m.class_name.c_str(), id.c_str(), m.box_iou, distance.c_str());
    out += line;
  }
  out += "\nMap objects of the annotated classes matching no annotation (box IoU < 0.25): ";
  if (matches.unmatched_prediction_ids.empty()) out += "none";
  for (size_t k = 0; k < matches.unmatched_prediction_ids.size(); ++k) {
    const int id = matches.unmatched_prediction_ids[k];
    for (const EvaluatedPrediction& p : predictions) {
      if (p.id != id) continue;
      std::snprintf(line, sizeof(line), "%s#%d %s", k > 0 ? ", " : "", id, p.class_name.c_str());
      out += line;
    }
  }
  out += "\n";
  return out;
}

}  // namespace mvod
