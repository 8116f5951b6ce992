#include "multiview_object_detection/pipeline/map/view_consensus.h"

#include <algorithm>
#include <cstddef>

namespace mvod {

namespace {

// An end is where at least this share of the views reach.
constexpr double kEndQuantile = 0.25;

// The q-quantile of values (not empty), the lower of two at a tie.
double quantile(std::vector<double> values, double q) {
  const std::size_t k =
      std::min(values.size() - 1, static_cast<std::size_t>(q * static_cast<double>(values.size())));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

bool isFinite(const OrientedBox& box) {
  return box.center_m.allFinite() && box.size_m.allFinite() && box.rotation.allFinite();
}

}  // namespace

bool viewConsensusBox(const std::vector<OrientedBox>& view_boxes, double max_disagreement_m,
                      OrientedBox* box) {
  if (!(max_disagreement_m > 0.0) || !isFinite(*box)) return false;
  std::vector<const OrientedBox*> views;
  views.reserve(view_boxes.size());
  for (const OrientedBox& view : view_boxes) {
    if (isFinite(view)) views.push_back(&view);
  }
  if (static_cast<int>(views.size()) < kViewConsensusMinViews) return false;
  Eigen::Vector3d center_m = box->center_m;
  Eigen::Vector3d size_m = box->size_m;
  std::vector<double> lower_m(views.size());
  std::vector<double> upper_m(views.size());
  for (int a = 0; a < 3; ++a) {
    const Eigen::Vector3d axis = box->rotation.col(a);
    for (std::size_t v = 0; v < views.size(); ++v) {
      // The view's box along the axis: its centre, plus and minus half its edges' projections.
      const double middle_m = axis.dot(views[v]->center_m - box->center_m);
      const double half_m =
          0.5 * (views[v]->rotation.transpose() * axis).cwiseAbs().dot(views[v]->size_m);
      lower_m[v] = middle_m - half_m;
      upper_m[v] = middle_m + half_m;
    }
    const double half_union_m = 0.5 * box->size_m(a);
    const double low_m = std::max(-half_union_m, quantile(lower_m, kEndQuantile));
    const double high_m = std::min(half_union_m, quantile(upper_m, 1.0 - kEndQuantile));
    if (!(high_m > low_m) || !(box->size_m(a) - (high_m - low_m) <= max_disagreement_m)) {
      return false;
    }
    center_m += 0.5 * (low_m + high_m) * axis;
    size_m(a) = high_m - low_m;
  }
  box->center_m = center_m;
  box->size_m = size_m;
  return true;
}

}  // namespace mvod
