#include "multiview_object_detection/pipeline/map/amodal_completion.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "multiview_object_detection/pipeline/utils/voxel_key.h"

namespace mvod {

Status AmodalCompletion::Config::isValid() const {
  if (!(std::isfinite(cell_size_m) && cell_size_m >= 0.01 && cell_size_m <= 0.5)) {
    return Status::Error("amodal cell_size_m must be in [0.01, 0.5] m (got " +
                         std::to_string(cell_size_m) + ")");
  }
  if (!(max_thin_ratio > 0.0 && max_thin_ratio <= 1.0)) {
    return Status::Error("amodal max_thin_ratio must be in (0, 1] (got " +
                         std::to_string(max_thin_ratio) + ")");
  }
  if (!(std::isfinite(free_margin_m) && free_margin_m >= 0.0)) {
    return Status::Error("amodal free_margin_m must be a finite value >= 0 (got " +
                         std::to_string(free_margin_m) + ")");
  }
  if (!(max_free_share >= 0.0 && max_free_share <= 1.0)) {
    return Status::Error("amodal max_free_share must be in [0, 1] (got " +
                         std::to_string(max_free_share) + ")");
  }
  if (!(std::isfinite(min_free_ratio) && min_free_ratio >= 1.0)) {
    return Status::Error("amodal min_free_ratio must be a finite value >= 1 (got " +
                         std::to_string(min_free_ratio) + ")");
  }
  if (min_in_view < 1) {
    return Status::Error("amodal min_in_view must be >= 1 (got " + std::to_string(min_in_view) +
                         ")");
  }
  if (min_observations < 1) {
    return Status::Error("amodal min_observations must be >= 1 (got " +
                         std::to_string(min_observations) + ")");
  }
  return Status::Ok();
}

std::string AmodalCompletion::Config::print() const {
  std::ostringstream out;
  out << "enable: " << (enable ? "true" : "false") << "\n"
      << "cell_size_m: " << cell_size_m << "\n"
      << "max_thin_ratio: " << max_thin_ratio << "\n"
      << "free_margin_m: " << free_margin_m << "\n"
      << "max_free_share: " << max_free_share << "\n"
      << "min_free_ratio: " << min_free_ratio << "\n"
      << "min_in_view: " << min_in_view << "\n"
      << "min_observations: " << min_observations << "\n";
  return out.str();
}

int AmodalCompletion::thinAxis(const OrientedBox& box, double depth_m) const {
  if (!config_.enable || !(depth_m > 0.0) || !box.size_m.allFinite()) return -1;
  const int axis = box.size_m.x() <= box.size_m.y() ? 0 : 1;
  return box.size_m[axis] < config_.max_thin_ratio * depth_m ? axis : -1;
}

template <typename Visit>
void AmodalCompletion::forEachCell(const OrientedBox& box, int axis, double depth_m,
                                   double floor_height_m, Visit visit) const {
  const Eigen::Vector3d a = box.rotation.col(axis);      // thin, horizontal
  const Eigen::Vector3d b = box.rotation.col(1 - axis);  // wide, horizontal
  const Eigen::Vector3d up = box.rotation.col(2);
  const double half_thin = 0.5 * box.size_m[axis];
  const double half_wide = 0.5 * box.size_m[1 - axis];
  const double reach = depth_m - box.size_m[axis];  // beyond the face
  // Below the box: what hides the rest of the object (a table top) hides its lower part. Beside
  // the visible part itself the views see open air on both sides (over the table).
  const double top = up.dot(box.center_m) - 0.5 * box.size_m.z();
  double bottom = top - depth_m;
  const double cell = config_.cell_size_m;
  if (std::isfinite(floor_height_m)) bottom = std::max(bottom, floor_height_m + 0.5 * cell);
  if (!(reach > 0.0) || !(top > bottom)) return;
  // The world cells of the region's bounding box; their centres are tested against the region.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e18);
  Eigen::Vector3d hi = Eigen::Vector3d::Constant(-1e18);
  const double c_a = a.dot(box.center_m);
  const double c_b = b.dot(box.center_m);
  for (int i = 0; i < 8; ++i) {
    const double s_a = (i & 1) ? half_thin + reach : -(half_thin + reach);
    const double s_b = (i & 2) ? half_wide : -half_wide;
    const double h = (i & 4) ? top : bottom;
    const Eigen::Vector3d corner =
        box.center_m + a * s_a + b * s_b + up * (h - up.dot(box.center_m));
    lo = lo.cwiseMin(corner);
    hi = hi.cwiseMax(corner);
  }
  const Eigen::Vector3i first = (lo / cell).array().floor().cast<int>();
  const Eigen::Vector3i last = (hi / cell).array().floor().cast<int>();
  // A region ~1.5 m across at 5 cm is ~10^4 cells; far more means a degenerate box.
  const Eigen::Vector3i count = last - first + Eigen::Vector3i::Ones();
  if (static_cast<double>(count.x()) * count.y() * count.z() > 2e6) return;
  for (int x = first.x(); x <= last.x(); ++x) {
    for (int y = first.y(); y <= last.y(); ++y) {
      for (int z = first.z(); z <= last.z(); ++z) {
        const Eigen::Vector3d centre = (Eigen::Vector3d(x, y, z).array() + 0.5) * cell;
        const double h = up.dot(centre);
        if (h < bottom || h > top) continue;
        if (std::abs(b.dot(centre) - c_b) > half_wide) continue;
        const double along = a.dot(centre) - c_a;
        const double beyond = std::abs(along) - half_thin;
        if (!(beyond > 0.0) || beyond > reach) continue;
        visit(packVoxel(Eigen::Vector3i(x, y, z)), centre.cast<float>(), along > 0.0 ? 1 : -1);
      }
    }
  }
}

void AmodalCompletion::countFreeSpace(const DepthView& view, const OrientedBox& box, double depth_m,
                                      double floor_height_m, FreeSpaceMap* free_space) const {
  const int axis = thinAxis(box, depth_m);
  if (axis < 0 || free_space == nullptr) return;
  forEachCell(box, axis, depth_m, floor_height_m,
              [&](std::int64_t key, const Eigen::Vector3f& centre, int) {
                const DepthView::Visibility seen = view.visibility(centre, config_.free_margin_m);
                if (seen == DepthView::Visibility::kNotInView) return;
                FreeSpaceCount& count = (*free_space)[key];
                if (count.in_view == UINT16_MAX) return;
                ++count.in_view;
                if (seen == DepthView::Visibility::kSeenFree) ++count.seen_free;
              });
}

AmodalCompletion::Decision AmodalCompletion::decide(const OrientedBox& box, double depth_m,
                                                    double floor_height_m,
                                                    const FreeSpaceMap& free_space) const {
  Decision decision;
  decision.axis = thinAxis(box, depth_m);
  if (decision.axis < 0) return decision;
  forEachCell(box, decision.axis, depth_m, floor_height_m,
              [&](std::int64_t key, const Eigen::Vector3f&, int side) {
                const auto it = free_space.find(key);
                if (it == free_space.end()) return;
                const int i = side > 0 ? 0 : 1;
                decision.in_view[i] += it->second.in_view;
                decision.seen_free[i] += it->second.seen_free;
              });
  if (decision.in_view[0] < config_.min_in_view || decision.in_view[1] < config_.min_in_view) {
    return decision;
  }
  // The side seen through less; the other must have been seen through clearly more often.
  const int hidden = decision.freeShare(0) <= decision.freeShare(1) ? 0 : 1;
  const double hidden_share = decision.freeShare(hidden);
  const double other_share = decision.freeShare(1 - hidden);
  if (hidden_share > config_.max_free_share) return decision;
  if (!(other_share > 0.0) || other_share < config_.min_free_ratio * hidden_share) return decision;
  decision.side = hidden == 0 ? 1 : -1;
  return decision;
}

OrientedBox AmodalCompletion::complete(const OrientedBox& box, const Decision& decision,
                                       double depth_m, double floor_height_m) {
  if (decision.axis < 0 || decision.side == 0 || !(depth_m > box.size_m[decision.axis])) {
    return box;
  }
  OrientedBox completed = box;
  const double grow = depth_m - box.size_m[decision.axis];
  completed.size_m[decision.axis] = depth_m;
  completed.center_m += box.rotation.col(decision.axis) * (0.5 * grow * decision.side);
  const Eigen::Vector3d up = box.rotation.col(2);
  const double bottom = up.dot(box.center_m) - 0.5 * box.size_m.z();
  const double top = bottom + box.size_m.z();
  if (std::isfinite(floor_height_m) && floor_height_m < bottom && top > floor_height_m) {
    completed.size_m.z() = top - floor_height_m;
    completed.center_m += up * (0.5 * (top + floor_height_m) - up.dot(box.center_m));
  }
  return completed;
}

}  // namespace mvod
