#include "multiview_object_detection/ros/label_placement.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <vector>

#include "multiview_object_detection/pipeline/types/oriented_box.h"

namespace mvod {
namespace {

constexpr double kCharWidth = 0.6;         // rviz's character width, in text heights (about)
constexpr double kClearanceM = 0.08;       // between a box top and the lowest label over it
constexpr double kLineSpacing = 1.5;       // between the lines of a column, in text heights
constexpr double kOtherColumnReach = 1.5;  // see the lines below
constexpr double kColumnLiftM = 0.4;  // a column's lowest line over its group's highest top: clear
                                      // of the clouds around it in an oblique view

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
                                        double text_height_m) {
  const size_t n = std::min(objects.size(), texts.size());
  const Eigen::Vector3d up = labelsUp(objects);
  // In id order; below, i and k index this order.
  std::vector<size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](size_t a, size_t b) { return objects[a]->id < objects[b]->id; });
  std::vector<Eigen::Vector3d> floor_m(n), top_m(n);  // box centre in the floor plane; box top
  std::vector<double> lowest_m(n), half_width_m(n);   // lowest label height; reach around column
  for (size_t i = 0; i < n; ++i) {
    const OrientedBox& box = objects[order[i]]->box;
    double half_up_m = 0.0;  // the box's half extent along up
    for (int a = 0; a < 3; ++a) {
      half_up_m += 0.5 * std::abs(box.size_m[a]) * std::abs(box.rotation.col(a).dot(up));
    }
    top_m[i] = box.center_m + half_up_m * up;
    lowest_m[i] = top_m[i].dot(up) + kClearanceM + 0.5 * text_height_m;
    floor_m[i] = top_m[i] - top_m[i].dot(up) * up;
    half_width_m[i] =
        0.5 * kCharWidth * text_height_m * static_cast<double>(texts[order[i]].size());
  }
  // Columns, in id order: a label joins the nearest column whose owner's reach meets its own
  // (text half widths), else it starts a column over its own box. Chains of neighbours do not merge
  // columns: a row of objects along a counter gets several short columns, not one tall one.
  std::vector<size_t> owner(n);  // per label: the first label of its column
  std::vector<size_t> owners;
  for (size_t i = 0; i < n; ++i) {
    owner[i] = i;
    double nearest_m = std::numeric_limits<double>::infinity();
    for (const size_t o : owners) {
      const double apart_m = (floor_m[i] - floor_m[o]).norm();
      if (apart_m < half_width_m[i] + half_width_m[o] && apart_m < nearest_m) {
        owner[i] = o;
        nearest_m = apart_m;
      }
    }
    if (owner[i] == i) owners.push_back(i);
  }
  // Each column's base: above the highest box of its members, lifted when it has several.
  std::vector<double> base_m(n, -std::numeric_limits<double>::infinity());
  std::vector<int> members(n, 0);
  for (size_t i = 0; i < n; ++i) {
    base_m[owner[i]] = std::max(base_m[owner[i]], lowest_m[i]);
    ++members[owner[i]];
  }
  for (const size_t o : owners) {
    if (members[o] > 1) base_m[o] += kColumnLiftM;
  }
  // Lines, in id order: the lowest line at or over the column's base that keeps a line's spacing
  // from every label placed before whose text could reach this one (its own column's, and those
  // of columns close by).
  const double spacing_m = kLineSpacing * text_height_m;
  std::vector<double> height_m(n, 0.0);
  std::vector<LabelPlacement> placements(n);
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d& at = floor_m[owner[i]];
    std::vector<size_t> neighbours;
    for (size_t k = 0; k < i; ++k) {
      // Other columns' labels count from farther: rviz's oblique view brings a column behind or in
      // front of this one closer on the screen than on the floor.
      const double reach_m =
          (owner[k] == owner[i] ? 1.0 : kOtherColumnReach) * (half_width_m[i] + half_width_m[k]);
      if ((floor_m[owner[k]] - at).norm() < reach_m) {
        neighbours.push_back(k);
      }
    }
    std::vector<double> candidates_m = {base_m[owner[i]]};
    for (const size_t k : neighbours) candidates_m.push_back(height_m[k] + spacing_m);
    std::sort(candidates_m.begin(), candidates_m.end());
    for (const double z_m : candidates_m) {
      if (z_m < base_m[owner[i]]) continue;
      const bool free = std::none_of(neighbours.begin(), neighbours.end(), [&](size_t k) {
        return std::abs(height_m[k] - z_m) < spacing_m - 1e-9;
      });
      if (free) {
        height_m[i] = z_m;
        break;
      }
    }
    placements[order[i]] = {at + height_m[i] * up, top_m[i]};
  }
  return placements;
}

}  // namespace mvod
