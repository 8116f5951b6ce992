#include "multiview_object_detection/pipeline/map/keyframe_history.h"

#include <algorithm>
#include <atomic>
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
  if (Status s = checkParameterRange("corrections/max_memory_mb", max_memory_mb); !s) return s;
  return Status::Ok();
}

std::string KeyframeHistory::Config::print() const {
  std::ostringstream out;
  out << "enable: " << (enable ? "true" : "false") << "\n"
      << "stamp_tolerance_s: " << stamp_tolerance_s << "\n"
      << "max_memory_mb: " << max_memory_mb << "\n";
  return out.str();
}

void KeyframeHistory::setConfig(const Config& config) {
  config_ = config;
  if (!config_.enable) {
    clear();
    return;
  }
  enforceBound();
}

void KeyframeHistory::add(KeyframeRecord record) {
  if (!config_.enable) return;
  static std::atomic<std::uint64_t> next_uid{1};
  record.uid = next_uid++;
  record.revision = 0;
  records_.push_back(std::move(record));
  enforceBound();
}

void coarsenDepth(KeyframeRecord* record) {
  if (record->depth.empty() || record->depth_coarse) return;
  const cv::Mat& depth = record->depth;
  cv::Mat coarse(depth.rows / 2 + depth.rows % 2, depth.cols / 2 + depth.cols % 2, CV_16UC1);
  for (int v = 0; v < coarse.rows; ++v) {
    auto* out = coarse.ptr<std::uint16_t>(v);
    if (depth.type() == CV_16UC1) {
      const auto* in = depth.ptr<std::uint16_t>(2 * v);
      for (int u = 0; u < coarse.cols; ++u) out[u] = in[2 * u];
    } else {
      // Metres to millimetres; no depth (0, NaN) and beyond 65.5 m stay no depth.
      const auto* in = depth.ptr<float>(2 * v);
      for (int u = 0; u < coarse.cols; ++u) {
        const float mm = std::round(in[2 * u] * 1000.f);
        out[u] = mm >= 1.f && mm <= 65535.f ? static_cast<std::uint16_t>(mm) : 0;
      }
    }
  }
  // Old pixel 2k is new pixel k: u' = u / 2 (pixel centres at integers, depth_view.h).
  CameraIntrinsics& K = record->K_depth;
  K.fx /= 2.0;
  K.fy /= 2.0;
  K.cx /= 2.0;
  K.cy /= 2.0;
  K.width = coarse.cols;
  K.height = coarse.rows;
  record->depth = coarse;
  record->depth_coarse = true;
  ++record->revision;
}

void KeyframeHistory::enforceBound() {
  const double budget_bytes = config_.max_memory_mb * 1024.0 * 1024.0;
  Usage now = usage();
  while (static_cast<double>(now.bytes) > budget_bytes && !records_.empty()) {
    if (static_cast<double>(now.depth_bytes) > budget_bytes / 4.0) {
      degradeOldestDepth(now.coarse_depth < now.full_depth);
    } else {
      records_.pop_front();
      ++forgotten_;
    }
    now = usage();
  }
}

void KeyframeHistory::degradeOldestDepth(bool coarsen) {
  // With depth, oldest first: the coarse ones, then the full ones. A full one becomes coarse while
  // they are fewer (the older half of them is coarse), else the oldest gives up its depth.
  for (KeyframeRecord& record : records_) {
    if (record.depth.empty() || (coarsen && record.depth_coarse)) continue;
    if (coarsen) {
      coarsenDepth(&record);
    } else {
      record.depth.release();
      record.depth_coarse = false;
      ++record.revision;
    }
    return;
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

KeyframeHistory::Usage KeyframeHistory::usage() const {
  Usage usage;
  usage.forgotten = forgotten_;
  for (const KeyframeRecord& record : records_) {
    usage.bytes += record.memoryBytes();
    ++usage.keyframes;
    if (record.depth.empty()) {
      ++usage.views_only;
    } else {
      usage.depth_bytes += record.depth.total() * record.depth.elemSize();
      ++(record.depth_coarse ? usage.coarse_depth : usage.full_depth);
    }
    for (const RecordedView& view : record.views) {
      if (view.cut != nullptr) usage.cut_bytes += view.cut->memoryBytes();
    }
  }
  return usage;
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
