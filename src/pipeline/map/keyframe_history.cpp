#include "multiview_object_detection/pipeline/map/keyframe_history.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <sstream>

#include "multiview_object_detection/pipeline/map/depth_view.h"
#include "multiview_object_detection/pipeline/map/object_database.h"
#include "multiview_object_detection/pipeline/types/parameter_ranges.h"
#include "multiview_object_detection/pipeline/utils/radix_sort.h"
#include "multiview_object_detection/pipeline/utils/voxel_key.h"

namespace mvod {

std::size_t RecordedCut::memoryBytes() const {
  return sizeof(RecordedCut) + cut_W.capacity() * sizeof(Eigen::Vector3f) +
         normals_W.capacity() * sizeof(Eigen::Vector3f) +
         outside_keys.capacity() * sizeof(std::int64_t);
}

bool KeyframeRecord::corrected() const { return T_W_D.matrix() != T_W_D_recorded.matrix(); }

std::size_t KeyframeRecord::memoryBytes() const {
  std::size_t bytes = sizeof(KeyframeRecord) + name.capacity();
  if (!depth.empty()) bytes += depth.total() * depth.elemSize();
  for (const RecordedView& view : views) {
    bytes += sizeof(RecordedView) + view.class_name.capacity();
    if (view.cut != nullptr) bytes += view.cut->memoryBytes();
  }
  return bytes;
}

Status KeyframeHistory::Config::isValid() const {
  if (!(std::isfinite(stamp_tolerance_s) && stamp_tolerance_s >= 0.0 && stamp_tolerance_s <= 1.0)) {
    return Status::Error("stamp_tolerance_s must be in [0, 1] (got " +
                         std::to_string(stamp_tolerance_s) + ")");
  }
  if (Status s =
          checkParameterRange("corrections/max_keyframes_with_depth", max_keyframes_with_depth);
      !s) {
    return s;
  }
  return Status::Ok();
}

std::string KeyframeHistory::Config::print() const {
  std::ostringstream out;
  out << "enable: " << (enable ? "true" : "false") << "\n"
      << "stamp_tolerance_s: " << stamp_tolerance_s << "\n"
      << "max_keyframes_with_depth: " << max_keyframes_with_depth << "\n";
  return out.str();
}

void KeyframeHistory::setConfig(const Config& config) {
  config_ = config;
  if (!config_.enable) records_.clear();
}

void KeyframeHistory::add(KeyframeRecord record) {
  if (!config_.enable) return;
  records_.push_back(std::move(record));
  // The oldest keyframes give up their depth first.
  std::size_t with_depth = 0;
  for (auto it = records_.rbegin(); it != records_.rend(); ++it) {
    if (it->depth.empty()) continue;
    if (++with_depth > static_cast<std::size_t>(config_.max_keyframes_with_depth)) {
      it->depth.release();
    }
  }
}

bool isSamePose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  // The Frobenius norm of the rotations' difference is sqrt(8) sin(angle / 2): about 1.4 angle.
  return (a.translation() - b.translation()).norm() <= kSamePoseTranslation_m &&
         (a.linear() - b.linear()).norm() <= std::sqrt(2.0) * kSamePoseRotation_rad;
}

std::vector<std::size_t> KeyframeHistory::correct(const std::vector<PoseCorrection>& corrections,
                                                  std::vector<PoseCorrection>* unmatched) {
  // The records by stamp (they are in keyframe order, which a replayed bag need not keep).
  std::vector<std::pair<double, std::size_t>> by_stamp;
  by_stamp.reserve(records_.size());
  for (std::size_t i = 0; i < records_.size(); ++i) by_stamp.emplace_back(records_[i].stamp_s, i);
  std::sort(by_stamp.begin(), by_stamp.end());
  std::vector<std::size_t> changed;
  for (const PoseCorrection& correction : corrections) {
    const auto later = std::lower_bound(by_stamp.begin(), by_stamp.end(),
                                        std::make_pair(correction.stamp_s, std::size_t{0}));
    std::size_t best = records_.size();
    double best_dt = config_.stamp_tolerance_s;
    for (auto it : {later, later == by_stamp.begin() ? by_stamp.end() : std::prev(later)}) {
      if (it == by_stamp.end()) continue;
      const double dt = std::abs(it->first - correction.stamp_s);
      if (dt <= best_dt) {
        best_dt = dt;
        best = it->second;
      }
    }
    if (best == records_.size()) {
      if (unmatched != nullptr) unmatched->push_back(correction);
      continue;
    }
    KeyframeRecord& record = records_[best];
    Eigen::Isometry3d T_W_D = correction.T_W_C * record.T_C_D;
    // The recorded pose, as a path or a pose file carries it: the recorded pose itself, so that
    // the views are fused again exactly as they were made.
    if (isSamePose(T_W_D, record.T_W_D_recorded)) T_W_D = record.T_W_D_recorded;
    if (isSamePose(T_W_D, record.T_W_D)) continue;
    record.T_W_D = T_W_D;
    changed.push_back(best);
  }
  std::sort(changed.begin(), changed.end());
  changed.erase(std::unique(changed.begin(), changed.end()), changed.end());
  return changed;
}

std::size_t KeyframeHistory::memoryBytes() const {
  std::size_t bytes = 0;
  for (const KeyframeRecord& record : records_) bytes += record.memoryBytes();
  return bytes;
}

namespace {

// The voxels (of the grid to_size_m) that `correction` moves the centres of `keys` (of the grid
// from_size_m) into, ascending, each once.
std::vector<std::int64_t> movedKeys(const std::vector<std::int64_t>& keys,
                                    const Eigen::Isometry3d& correction, double from_size_m,
                                    double to_size_m) {
  std::vector<std::uint64_t> moved;
  moved.reserve(keys.size());
  const Eigen::Isometry3f correction_f = correction.cast<float>();
  for (const std::int64_t key : keys) {
    const Eigen::Vector3f centre =
        ((unpackVoxel(key).cast<double>().array() + 0.5) * from_size_m).matrix().cast<float>();
    moved.push_back(static_cast<std::uint64_t>(voxelKeyOf(correction_f * centre, to_size_m)));
  }
  radixSortKeys(&moved);
  std::vector<std::int64_t> unique;
  unique.reserve(moved.size());
  for (const std::uint64_t entry : moved) {
    const std::int64_t key = static_cast<std::int64_t>(entry);
    if (unique.empty() || unique.back() != key) unique.push_back(key);
  }
  return unique;
}

bool isIdentity(const Eigen::Isometry3d& T) { return T.matrix() == Eigen::Matrix4d::Identity(); }

}  // namespace

ObjectObservation replayedObservation(const RecordedView& view, const Eigen::Isometry3d& correction,
                                      double voxel_size_m) {
  ObjectObservation observation;
  observation.class_id = view.class_id;
  observation.class_name = view.class_name;
  observation.probability = view.probability;
  const bool moved = !isIdentity(correction);
  const RecordedCut& cut = *view.cut;
  observation.segment_W = moved ? transformCloud(cut.cut_W, correction) : cut.cut_W;
  observation.segment_normals_W = cut.normals_W;
  if (moved) {
    const Eigen::Matrix3f R = correction.linear().cast<float>();
    for (Eigen::Vector3f& n : observation.segment_normals_W) {
      if (n.allFinite()) n = R * n;
    }
  }
  OrientedBox box = view.box;
  box.center_m = correction * view.box.center_m;
  box.rotation = correction.linear() * view.box.rotation;
  observation.box = moved ? box : view.box;
  observation.yaw_rad = view.yaw_rad;  // moved boxes: the caller takes the yaw about gravity
  auto keys = std::make_shared<FusionKeys>(
      makeFusionKeys(observation.segment_W, PointCloud(), voxel_size_m));
  const std::vector<std::int64_t> outside =
      cut.voxel_size_m == voxel_size_m && !moved
          ? cut.outside_keys
          : movedKeys(cut.outside_keys, correction, cut.voxel_size_m, voxel_size_m);
  std::set_difference(outside.begin(), outside.end(), keys->cut.begin(), keys->cut.end(),
                      std::back_inserter(keys->outside));
  observation.fusion_keys = std::move(keys);
  return observation;
}

}  // namespace mvod
