#include "multiview_object_detection/ros/label_placement.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <vector>

#include "multiview_object_detection/pipeline/types/oriented_box.h"

namespace mvod {
namespace {

constexpr double kCharWidth = 0.6;    // rviz's character width, in text heights (about)
constexpr double kClearanceM = 0.05;  // between a box top and the label over it
constexpr double kLineSpacing = 1.3;  // between two labels one over the other, in text heights

// The boxes' third axes (Eq. 4 makes them the floor normal): their mean, pointing to +z; z when
// there are none.
Eigen::Vector3d labelsUp(const std::vector<const MapObject*>& objects) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const MapObject* object : objects) {
    const Eigen::Vector3d axis = object->box.rotation.col(2);
    sum += (sum.dot(axis) < 0.0 ? -1.0 : 1.0) * axis;
  }
  if (sum.norm() < 1e-9) return Eigen::Vector3d::UnitZ();
  return sum.z() < 0.0 ? Eigen::Vector3d(-sum.normalized()) : Eigen::Vector3d(sum.normalized());
}

}  // namespace

std::vector<LabelPlacement> placeLabels(const std::vector<const MapObject*>& objects,
                                        const std::vector<std::string>& texts,
                                        const std::vector<double>& text_heights_m) {
  const size_t n = std::min({objects.size(), texts.size(), text_heights_m.size()});
  const Eigen::Vector3d up = labelsUp(objects);
  // In id order; below, i and k index this order.
  std::vector<size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](size_t a, size_t b) { return objects[a]->id < objects[b]->id; });
  std::vector<Eigen::Vector3d> floor_m(n), top_m(n);  // box centre in the floor plane; box top
  std::vector<double> lowest_m(n), half_width_m(n);   // lowest label height; reach around column
  std::vector<double> text_m(n);                      // text height
  for (size_t i = 0; i < n; ++i) {
    const OrientedBox& box = objects[order[i]]->box;
    text_m[i] = text_heights_m[order[i]];
    double half_up_m = 0.0;  // the box's half extent along up
    for (int a = 0; a < 3; ++a) {
      half_up_m += 0.5 * std::abs(box.size_m[a]) * std::abs(box.rotation.col(a).dot(up));
    }
    top_m[i] = box.center_m + half_up_m * up;
    lowest_m[i] = top_m[i].dot(up) + kClearanceM + 0.5 * text_m[i];
    floor_m[i] = top_m[i] - top_m[i].dot(up) * up;
    half_width_m[i] = 0.5 * kCharWidth * text_m[i] * static_cast<double>(texts[order[i]].size());
  }
  // Lines, in id order: each label over its own box, on the lowest line at or over its base that
  // keeps a line's spacing from every label placed before whose text could reach this one (their
  // half widths apart on the floor). Only such neighbours lift a label; the rest stay on their box.
  // Two labels' centres keep a line's spacing of their mean text height.
  const auto spacing_m = [&](size_t a, size_t b) {
    return kLineSpacing * 0.5 * (text_m[a] + text_m[b]);
  };
  std::vector<double> height_m(n, 0.0);
  std::vector<LabelPlacement> placements(n);
  for (size_t i = 0; i < n; ++i) {
    std::vector<size_t> neighbours;
    for (size_t k = 0; k < i; ++k) {
      if ((floor_m[k] - floor_m[i]).norm() < half_width_m[i] + half_width_m[k]) {
        neighbours.push_back(k);
      }
    }
    std::vector<double> candidates_m = {lowest_m[i]};
    for (const size_t k : neighbours) candidates_m.push_back(height_m[k] + spacing_m(i, k));
    std::sort(candidates_m.begin(), candidates_m.end());
    for (const double z_m : candidates_m) {
      if (z_m < lowest_m[i]) continue;
      const bool free = std::none_of(neighbours.begin(), neighbours.end(), [&](size_t k) {
        return std::abs(height_m[k] - z_m) < spacing_m(i, k) - 1e-9;
      });
      if (free) {
        height_m[i] = z_m;
        break;
      }
    }
    placements[order[i]] = {floor_m[i] + height_m[i] * up, top_m[i]};
  }
  return placements;
}

}  // namespace mvod
