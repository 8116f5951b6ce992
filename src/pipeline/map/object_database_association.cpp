// ObjectDatabase's association (evidence fusion): which object each detection of a keyframe joins,
// by the overlap of its cut with the objects' voxels, one detection per object and keyframe.
#include <algorithm>
#include <cstdint>
#include <tuple>
#include <vector>

#include "multiview_object_detection/pipeline/map/object_database.h"
#include "multiview_object_detection/pipeline/utils/voxel_key.h"
#include "object_database_detail.h"

namespace mvod {
namespace {

using object_database_detail::voxelKeys;

// A voxel of the object by the views' votes (inside >= outside). A new view's cut may lie in the
// shell of noise around the surface: surface_band_m selects the object's voxels for its box, not
// what it is matched on.
bool voted(const EvidenceMap& evidence, std::int64_t key) {
  const auto it = evidence.find(key);
  return it != evidence.end() && it->second.inside >= 1 && it->second.inside >= it->second.outside;
}

bool holds(const std::vector<std::int64_t>& sorted_keys, std::int64_t key) {
  return std::binary_search(sorted_keys.begin(), sorted_keys.end(), key);
}

// Whether `sorted_keys` holds a voxel within `reach` voxels of `key` (any of the (2r+1)^3).
bool holdsNear(const std::vector<std::int64_t>& sorted_keys, std::int64_t key, int reach) {
  if (holds(sorted_keys, key)) return true;
  const Eigen::Vector3i centre = unpackVoxel(key);
  for (int dx = -reach; dx <= reach; ++dx) {
    for (int dy = -reach; dy <= reach; ++dy) {
      for (int dz = -reach; dz <= reach; ++dz) {
        if (holds(sorted_keys, packVoxel(centre + Eigen::Vector3i(dx, dy, dz)))) return true;
      }
    }
  }
  return false;
}

}  // namespace

bool ObjectDatabase::takenThisKeyframe(const MapObject& object) const {
  if (!config_.no_fusion_within_keyframe) return false;
  return std::find(inserted_this_keyframe_.begin(), inserted_this_keyframe_.end(), object.id) !=
             inserted_this_keyframe_.end() ||
         std::find(fused_this_keyframe_.begin(), fused_this_keyframe_.end(), object.id) !=
             fused_this_keyframe_.end();
}

double ObjectDatabase::overlapShare(const MapObject& object, const std::vector<std::int64_t>& cut,
                                    int reach) {
  int shared = 0;
  for (const std::int64_t key : cut) {
    bool near = voted(object.evidence, key);
    if (!near && reach > 0) {
      const Eigen::Vector3i centre = unpackVoxel(key);
      for (int dx = -reach; dx <= reach && !near; ++dx) {
        for (int dy = -reach; dy <= reach && !near; ++dy) {
          for (int dz = -reach; dz <= reach && !near; ++dz) {
            near = voted(object.evidence, packVoxel(centre + Eigen::Vector3i(dx, dy, dz)));
          }
        }
      }
    }
    if (near) ++shared;
  }
  return cut.empty() ? 0.0 : static_cast<double>(shared) / cut.size();
}

bool ObjectDatabase::seenApart(const MapObject& object, const std::vector<std::int64_t>& mask,
                               const FusionKeys& keys, int reach) {
  // What the view says of the object's voxels: inside the detection's mask (this detection,
  // though its cut may have kept only part of it: a screen with little depth), or only on the
  // surface around it, outside the mask (something else: the book beside this one).
  int voxels = 0;
  int in_mask = 0;
  int left_out = 0;
  for (const auto& entry : object.evidence) {
    if (!(entry.second.inside >= 1 && entry.second.inside >= entry.second.outside)) continue;
    ++voxels;
    if (holdsNear(mask, entry.first, reach) || holdsNear(keys.cut, entry.first, reach)) {
      ++in_mask;
    } else if (holdsNear(keys.outside, entry.first, reach)) {
      ++left_out;
    }
  }
  return left_out > in_mask && 10 * left_out >= voxels;
}

std::vector<ObjectDatabase::Candidate> ObjectDatabase::candidatesOf(
    const ObjectObservation& observation, const FusionKeys& keys) {
  std::vector<Candidate> candidates;
  std::vector<std::int64_t> mask;  // the mask's voxels (points_W), when needed
  const bool by_overlap = config_.min_overlap_to_fuse > 0.0;
  const double gamma_m = priors_.fusionDistance(observation.class_name);
  for (auto& entry : objects_) {
    MapObject& object = entry.second;
    if (takenThisKeyframe(object)) continue;
    const bool same_class = object.class_name == observation.class_name;
    const bool has_evidence =
        !object.evidence.empty() && object.evidence_voxel_size_m == config_.fusion_voxel_size_m;
    Candidate candidate;
    candidate.object = &object;
    candidate.tier = same_class ? 0 : 1;
    // A completed box's centre lies in the part no view saw: the views' own box is matched.
    candidate.distance_m = (object.seenBox().center_m - observation.box.center_m).norm();
    const bool boxes_may_overlap =
        candidate.distance_m <= 0.5 * (object.box.size_m.norm() + observation.box.size_m.norm());
    const bool within_gamma = same_class && candidate.distance_m <= gamma_m;
    if (!boxes_may_overlap && !within_gamma) continue;
    const int reach = same_class ? config_.same_class_overlap_voxels : 0;
    if (by_overlap && has_evidence && boxes_may_overlap) {
      candidate.overlap = overlapShare(object, keys.cut, reach);
    }
    bool admissible = by_overlap && candidate.overlap >= config_.min_overlap_to_fuse;
    // Eq. 6's Γ_C for what overlaps too little (another side, a pose a little off), unless the
    // view saw the object and left it out of its cut.
    if (!admissible && within_gamma && has_evidence && mask.empty()) {
      mask = voxelKeys(observation.points_W, config_.fusion_voxel_size_m);
    }
    if (!admissible && within_gamma) {
      admissible =
          !has_evidence || !seenApart(object, mask, keys, config_.same_class_overlap_voxels);
    }
    if (admissible) candidates.push_back(candidate);
  }
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    return std::make_tuple(a.tier, -a.overlap, a.distance_m, a.object->id) <
           std::make_tuple(b.tier, -b.overlap, b.distance_m, b.object->id);
  });
  return candidates;
}

std::vector<int> ObjectDatabase::associate(
    const std::vector<const ObjectObservation*>& observations) {
  std::vector<int> object_ids(observations.size(), kAssociateNow);
  if (config_.disable_fusion || config_.fusion != "evidence" || observations.empty()) {
    return object_ids;
  }
  beginKeyframe(observations.front()->keyframe);
  // Every admissible pair of the keyframe, then the best pairs first: a detection takes its best
  // object unless a detection that fits that object better took it.
  struct Pair {
    Candidate candidate;
    size_t observation = 0;
  };
  std::vector<Pair> pairs;
  for (size_t k = 0; k < observations.size(); ++k) {
    const std::shared_ptr<const FusionKeys> keys = fusionKeysOf(*observations[k]);
    for (const Candidate& candidate : candidatesOf(*observations[k], *keys)) {
      pairs.push_back({candidate, k});
    }
  }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
    return std::make_tuple(a.candidate.tier, -a.candidate.overlap, a.candidate.distance_m,
                           a.candidate.object->id, a.observation) <
           std::make_tuple(b.candidate.tier, -b.candidate.overlap, b.candidate.distance_m,
                           b.candidate.object->id, b.observation);
  });
  std::vector<int> taken;
  for (const Pair& pair : pairs) {
    if (object_ids[pair.observation] != kAssociateNow) continue;
    const int id = pair.candidate.object->id;
    if (config_.no_fusion_within_keyframe &&
        std::find(taken.begin(), taken.end(), id) != taken.end()) {
      continue;
    }
    object_ids[pair.observation] = id;
    taken.push_back(id);
  }
  for (int& id : object_ids) {
    if (id == kAssociateNow) id = -1;
  }
  return object_ids;
}

}  // namespace mvod
