#include "multiview_object_detection/ros/label_placement.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "multiview_object_detection/pipeline/types/oriented_box.h"

namespace mvod {
namespace {

constexpr double kCharWidth = 0.6;    // rviz's character width, in text heights (about)
constexpr double kClearanceM = 0.08;  // between a box top and the lowest label over it
constexpr double kLineSpacing = 1.5;  // between the lines of a column, in text heights
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

// Union-find over the labels: which column each one joins.
class Columns {
 public:
  explicit Columns(size_t n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), 0); }
  size_t find(size_t i) {
    while (parent_[i] != i) i = parent_[i] = parent_[parent_[i]];
    return i;
  }
  // The column keeps the smaller root index: the oldest object when indices are in id order.
  bool join(size_t a, size_t b) {
    a = find(a);
    b = find(b);
    if (a == b) return false;
    parent_[std::max(a, b)] = std::min(a, b);
    return true;
  }

 private:
  std::vector<size_t> parent_;
};

}  // namespace

std::vector<LabelPlacement> placeLabels(const std::vector<const MapObject*>& objects,
                                        const std::vector<std::string>& texts,
                                        double text_height_m) {
  const size_t n = std::min(objects.size(), texts.size());
  const Eigen::Vector3d up = labelsUp(objects);
  // In id order; below, i and j index this order.
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
  // Labels join while their reaches meet: first around their own boxes, then around the columns
  // (a column's reach is its widest label's), until no two columns meet.
  Columns columns(n);
  std::vector<double> reach_m = half_width_m;  // per column (its root): its widest label's
  for (bool first = true, joined = true; joined; first = false) {
    joined = false;
    if (!first) {
      std::fill(reach_m.begin(), reach_m.end(), 0.0);
      for (size_t k = 0; k < n; ++k) {
        reach_m[columns.find(k)] = std::max(reach_m[columns.find(k)], half_width_m[k]);
      }
    }
    for (size_t i = 0; i < n; ++i) {
      for (size_t j = i + 1; j < n; ++j) {
        const size_t ci = columns.find(i), cj = columns.find(j);
        if (ci == cj) continue;
        const double apart_m =
            first ? (floor_m[i] - floor_m[j]).norm() : (floor_m[ci] - floor_m[cj]).norm();
        const double meet_m = first ? half_width_m[i] + half_width_m[j] : reach_m[ci] + reach_m[cj];
        if (apart_m < meet_m) joined |= columns.join(i, j);
      }
    }
  }
  // Each column's base: above the highest box of its group. Then one line per label, in id order.
  std::vector<double> base_m(n, -std::numeric_limits<double>::infinity());
  std::vector<int> members(n, 0);
  for (size_t i = 0; i < n; ++i) {
    base_m[columns.find(i)] = std::max(base_m[columns.find(i)], lowest_m[i]);
    ++members[columns.find(i)];
  }
  for (size_t c = 0; c < n; ++c) {
    if (members[c] > 1) base_m[c] += kColumnLiftM;
  }
  std::vector<int> lines_used(n, 0);
  std::vector<LabelPlacement> placements(n);
  for (size_t i = 0; i < n; ++i) {
    const size_t c = columns.find(i);
    const double height_m = base_m[c] + kLineSpacing * text_height_m * lines_used[c]++;
    placements[order[i]] = {floor_m[c] + height_m * up, top_m[i]};
  }
  return placements;
}

}  // namespace mvod
