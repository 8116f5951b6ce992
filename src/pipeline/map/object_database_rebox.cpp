// ObjectDatabase's re-boxing of fused objects (Eq. 7: the fused evidence re-segmented and
// re-boxed, in parallel over objects), amodal completion of their boxes, and merging duplicates.
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "multiview_object_detection/pipeline/map/object_database.h"
#include "multiview_object_detection/pipeline/map/view_consensus.h"
#include "multiview_object_detection/pipeline/utils/parallel.h"
#include "multiview_object_detection/pipeline/utils/radix_sort.h"
#include "multiview_object_detection/pipeline/utils/voxel_key.h"
#include "object_database_detail.h"

namespace mvod {

using object_database_detail::addClassScore;
using object_database_detail::addSignedDistances;

int ObjectDatabase::reboxPending(const FusedCloudProcessor& process, int threads) {
  std::vector<MapObject*> pending;
  std::vector<const DepthView*> views;
  pending.reserve(pending_rebox_.size());
  for (const int id : pending_rebox_) {
    const auto it = objects_.find(id);
    if (it == objects_.end() || it->second.evidence.empty()) continue;
    pending.push_back(&it->second);
    const auto view = pending_depth_views_.find(id);
    views.push_back(view != pending_depth_views_.end() ? view->second.get() : nullptr);
  }
  pending_rebox_.clear();
  // The keyframe's signed distances first, in chunks of voxels of every object: one large object
  // (a bed, ~10^5 voxels) would otherwise keep one core busy while the other idles.
  struct VoxelChunk {
    std::size_t object;
    std::size_t first;
    std::size_t last;
  };
  constexpr std::size_t kVoxelsPerChunk = 4096;
  std::vector<VoxelChunk> chunks;
  for (std::size_t k = 0; k < pending.size(); ++k) {
    if (views[k] == nullptr || !(config_.surface_band_m > 0.0)) continue;
    const std::size_t voxels = pending[k]->evidence.size();
    for (std::size_t first = 0; first < voxels; first += kVoxelsPerChunk) {
      chunks.push_back({k, first, std::min(voxels, first + kVoxelsPerChunk)});
    }
  }
  parallelForEach(chunks.size(), threads, [&](std::size_t c) {
    const VoxelChunk& chunk = chunks[c];
    addSignedDistances(*views[chunk.object], config_.fusion_voxel_size_m,
                       &pending[chunk.object]->evidence, chunk.first, chunk.last);
  });
  // Then each object's box, largest first, each thread taking the next object as it finishes.
  // Each job reads and writes its own object only (the map itself does not change meanwhile).
  std::vector<std::size_t> by_size(pending.size());
  for (std::size_t k = 0; k < by_size.size(); ++k) by_size[k] = k;
  std::stable_sort(by_size.begin(), by_size.end(), [&pending](std::size_t a, std::size_t b) {
    return pending[a]->evidence.size() > pending[b]->evidence.size();
  });
  parallelForEach(by_size.size(), threads,
                  [&](std::size_t j) { rebox(pending[by_size[j]], process, views[by_size[j]]); });
  pending_depth_views_.clear();
  return static_cast<int>(pending.size());
}

void ObjectDatabase::rebox(MapObject* object, const FusedCloudProcessor& process,
                           const DepthView* view) const {
  std::vector<Eigen::Vector3f> normals;
  const PointCloud supported = supportedVoxels(*object, &normals);
  object->points_W.clear();
  object->points_W.reserve(object->evidence.size());
  for (const auto& entry : object->evidence) object->points_W.push_back(voxelCentre(entry.first));
  PointCloud segment_W;
  OrientedBox box;
  double yaw_rad = object->yaw_rad;
  if (process && process(object->class_name, supported, normals, &segment_W, &box, &yaw_rad)) {
    object->segment_W = std::move(segment_W);
    object->box = box;
    object->yaw_rad = yaw_rad;
    viewConsensusBox(object->view_boxes, config_.view_consensus_m, &object->box);
    completeBox(object, view);
  }  // else: the previous box (completed or not) stays.
}

void ObjectDatabase::completeBox(MapObject* object, const DepthView* view) const {
  object->box_completed = false;
  if (!config_.amodal.enable || config_.fusion != "evidence") return;
  const ClassPrior* prior = priors_.find(object->class_name);
  if (prior == nullptr || !(prior->amodal_depth_m > 0.0)) return;
  // Completion works in the box's frame, its third axis up.
  if (!gravity_up_.isZero() && !(object->box.rotation.col(2).dot(gravity_up_) >= 0.999)) return;
  const AmodalCompletion completion(config_.amodal);
  if (object->free_space_cell_m != config_.amodal.cell_size_m) {
    object->free_space.clear();
    object->free_space_cell_m = config_.amodal.cell_size_m;
  }
  const double depth_m = prior->amodal_depth_m;
  if (view != nullptr) {
    completion.countFreeSpace(*view, object->box, depth_m, floor_height_m_, &object->free_space);
  }
  if (object->observations < config_.amodal.min_observations) return;
  const AmodalCompletion::Decision decision =
      completion.decide(object->box, depth_m, floor_height_m_, object->free_space);
  if (decision.side == 0) return;
  object->observed_box = object->box;
  object->box = AmodalCompletion::complete(object->box, decision, depth_m, floor_height_m_);
  object->box_completed = true;
}

bool ObjectDatabase::mergeInto(int into_id, int from_id, const FusedCloudProcessor& process) {
  const auto into_it = objects_.find(into_id);
  const auto from_it = objects_.find(from_id);
  if (into_id == from_id || into_it == objects_.end() || from_it == objects_.end()) return false;
  MapObject& into = into_it->second;
  const MapObject& from = from_it->second;
  if (into.evidence.empty() || from.evidence.empty() ||
      into.evidence_voxel_size_m != config_.fusion_voxel_size_m ||
      from.evidence_voxel_size_m != config_.fusion_voxel_size_m) {
    return false;
  }
  const auto saturated = [](std::uint16_t a, std::uint16_t b) {
    return static_cast<std::uint16_t>(std::min<int>(UINT16_MAX, int{a} + int{b}));
  };
  // In key order: the sums do not depend on the hash map's iteration order.
  std::vector<std::pair<std::uint64_t, const VoxelEvidence*>> voxels;
  voxels.reserve(from.evidence.size());
  for (const auto& entry : from.evidence) {
    voxels.emplace_back(static_cast<std::uint64_t>(entry.first), &entry.second);
  }
  radixSortByKey(&voxels);
  for (const auto& voxel : voxels) {
    VoxelEvidence& e = into.evidence[static_cast<std::int64_t>(voxel.first)];
    const VoxelEvidence& f = *voxel.second;
    e.inside = saturated(e.inside, f.inside);
    e.outside = saturated(e.outside, f.outside);
    e.normal_sum += f.normal_sum;
    e.sdf_sum += f.sdf_sum;
    e.sdf_count = saturated(e.sdf_count, f.sdf_count);
  }
  // The free space both saw around them (on one grid; otherwise into's alone), in key order.
  if (from.free_space_cell_m == into.free_space_cell_m && into.free_space_cell_m > 0.0) {
    std::vector<std::pair<std::uint64_t, FreeSpaceCount>> cells;
    cells.reserve(from.free_space.size());
    for (const auto& entry : from.free_space) {
      cells.emplace_back(static_cast<std::uint64_t>(entry.first), entry.second);
    }
    radixSortByKey(&cells);
    for (const auto& cell : cells) {
      FreeSpaceCount& c = into.free_space[static_cast<std::int64_t>(cell.first)];
      c.in_view = saturated(c.in_view, cell.second.in_view);
      c.seen_free = saturated(c.seen_free, cell.second.seen_free);
    }
  }
  // from's class scores (its own class, for a map saved before them) into into's vote.
  std::map<std::string, double> from_scores = from.class_scores;
  if (from_scores.empty()) from_scores[from.class_name] = from.probability * from.observations;
  for (const auto& entry : from_scores) addClassScore(entry.first, entry.second, &into);
  const int observations = into.observations + from.observations;
  if (observations > 0) {
    into.probability =
        (into.probability * into.observations + from.probability * from.observations) /
        observations;
  }
  into.observations = observations;
  into.first_keyframe = std::min(into.first_keyframe, from.first_keyframe);
  into.last_keyframe = std::max(into.last_keyframe, from.last_keyframe);
  into.first_seen_s = std::min(into.first_seen_s, from.first_seen_s);
  into.last_seen_s = std::max(into.last_seen_s, from.last_seen_s);
  // One object seen as two: the votes of both, its odds the better of the two.
  into.existence.log_odds = std::max(into.existence.log_odds, from.existence.log_odds);
  into.existence.detected += from.existence.detected;
  into.existence.missed += from.existence.missed;
  into.existence.seen_through += from.existence.seen_through;
  for (const OrientedBox& view_box : from.view_boxes) addViewBox(view_box, &into);
  remove(from_id);
  rebox(&into, process, nullptr);
  return true;
}

}  // namespace mvod
