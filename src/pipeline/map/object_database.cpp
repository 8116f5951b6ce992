#include "multiview_object_detection/pipeline/map/object_database.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <sstream>

#include "multiview_object_detection/pipeline/stages/point_cloud_filter.h"
#include "multiview_object_detection/pipeline/types/map_limits.h"
#include "multiview_object_detection/pipeline/types/parameter_ranges.h"
#include "multiview_object_detection/pipeline/utils/radix_sort.h"
#include "multiview_object_detection/pipeline/utils/voxel_key.h"
#include "object_database_detail.h"

namespace mvod {

using object_database_detail::addClassScore;
using object_database_detail::addSignedDistances;
using object_database_detail::voxelKeys;

Status ObjectDatabase::Config::isValid() const {
  if (Status s = checkParameterRange("database/fusion_voxel_size_m", fusion_voxel_size_m); !s)
    return s;
  if (!(min_overlap_to_fuse >= 0.0 && min_overlap_to_fuse <= 1.0)) {
    return Status::Error("min_overlap_to_fuse must be in [0, 1]");
  }
  if (!(same_class_overlap_voxels >= 0 && same_class_overlap_voxels <= 3)) {
    return Status::Error("same_class_overlap_voxels must be in [0, 3] (got " +
                         std::to_string(same_class_overlap_voxels) + ")");
  }
  if (!(std::isfinite(surface_band_m) && surface_band_m >= 0.0)) {
    return Status::Error("surface_band_m must be a finite value >= 0 (got " +
                         std::to_string(surface_band_m) + ")");
  }
  if (!(std::isfinite(view_consensus_m) && view_consensus_m >= 0.0)) {
    return Status::Error("view_consensus_m must be a finite value >= 0 (got " +
                         std::to_string(view_consensus_m) + ")");
  }
  const Status amodal_status = amodal.isValid();
  if (!amodal_status) return amodal_status;
  const Status existence_status = existence.isValid();
  if (!existence_status) return Status::Error("existence." + existence_status.message());
  if (fusion != "paper" && fusion != "evidence") {
    return Status::Error("fusion must be paper or evidence (got '" + fusion + "')");
  }
  return Status::Ok();
}

std::string ObjectDatabase::Config::print() const {
  std::ostringstream out;
  out << "fusion_voxel_size_m: " << fusion_voxel_size_m << "\n"
      << "no_fusion_within_keyframe: " << (no_fusion_within_keyframe ? "true" : "false") << "\n"
      << "disable_fusion: " << (disable_fusion ? "true" : "false") << "\n"
      << "fusion: " << fusion << "\n"
      << "min_overlap_to_fuse: " << min_overlap_to_fuse << "\n"
      << "same_class_overlap_voxels: " << same_class_overlap_voxels << "\n"
      << "surface_band_m: " << surface_band_m << "\n"
      << "view_consensus_m: " << view_consensus_m << "\n";
  std::istringstream amodal_lines(amodal.print());
  for (std::string line; std::getline(amodal_lines, line);) out << "amodal." << line << "\n";
  std::istringstream existence_lines(existence.print());
  for (std::string line; std::getline(existence_lines, line);) out << "existence." << line << "\n";
  return out.str();
}

namespace object_database_detail {

std::vector<std::int64_t> voxelKeys(const PointCloud& points_W, double voxel_size_m) {
  std::vector<std::uint64_t> keyed;
  keyed.reserve(points_W.size());
  for (const Eigen::Vector3f& p : points_W) {
    keyed.push_back(static_cast<std::uint64_t>(voxelKeyOf(p, voxel_size_m)));
  }
  radixSortKeys(&keyed);
  std::vector<std::int64_t> keys;
  keys.reserve(keyed.size());
  for (const std::uint64_t entry : keyed) {
    const std::int64_t key = static_cast<std::int64_t>(entry);
    if (keys.empty() || keys.back() != key) keys.push_back(key);
  }
  return keys;
}

}  // namespace object_database_detail

namespace {

void countInside(const std::vector<std::int64_t>& inside, EvidenceMap* evidence) {
  for (const std::int64_t key : inside) {
    VoxelEvidence& e = (*evidence)[key];
    if (e.inside < UINT16_MAX) ++e.inside;
  }
}

// The cut's normals into the voxels they lie in (the voxels are in `evidence` already).
void addNormals(const ObjectObservation& observation, double voxel_size_m, EvidenceMap* evidence) {
  if (observation.segment_normals_W.size() != observation.segment_W.size()) return;
  for (size_t i = 0; i < observation.segment_W.size(); ++i) {
    const Eigen::Vector3f& n = observation.segment_normals_W[i];
    if (!n.allFinite()) continue;
    const auto it = evidence->find(voxelKeyOf(observation.segment_W[i], voxel_size_m));
    if (it != evidence->end()) it->second.normal_sum += n;
  }
}

// One view's votes on an object's voxels (evidence, on the fusion grid): inside for the voxels of
// its cut, with the cut's normals, and outside for the voxels of the object it saw surface in but
// left out of the cut. Cost: the view's points, not the object's size.
void addVotes(const ObjectObservation& observation, const FusionKeys& keys, double voxel_size_m,
              EvidenceMap* evidence) {
  countInside(keys.cut, evidence);
  addNormals(observation, voxel_size_m, evidence);
  for (const std::int64_t key : keys.outside) {
    const auto it = evidence->find(key);
    if (it != evidence->end() && it->second.outside < UINT16_MAX) ++it->second.outside;
  }
}

}  // namespace

namespace object_database_detail {

// This view's signed distance of every voxel of the object it sees (the view's cost: the
// object's voxels, one projection each), over the entries [first, last): each voxel is one entry,
// so disjoint ranges can run in parallel with the same result.
void addSignedDistances(const DepthView& view, double voxel_size_m, EvidenceMap* evidence,
                        std::size_t first, std::size_t last) {
  for (std::size_t position = first; position < last; ++position) {
    EvidenceMap::value_type& entry = evidence->entry(position);
    VoxelEvidence& e = entry.second;
    if (e.sdf_count == UINT16_MAX) continue;
    const Eigen::Vector3f centre =
        ((unpackVoxel(entry.first).cast<double>().array() + 0.5) * voxel_size_m)
            .matrix()
            .cast<float>();
    float sdf_m = 0.f;
    if (!view.signedDistance(centre, &sdf_m)) continue;
    e.sdf_sum += sdf_m;
    ++e.sdf_count;
  }
}

void addSignedDistances(const DepthView& view, double voxel_size_m, EvidenceMap* evidence) {
  addSignedDistances(view, voxel_size_m, evidence, 0, evidence->size());
}

// Evidence fusion's class vote: `score` more for `class_name`; the object takes the class with the
// largest sum. An object without scores yet (a map saved before them) starts from its own class.
void addClassScore(const std::string& class_name, double score, MapObject* object) {
  std::map<std::string, double>& scores = object->class_scores;
  if (scores.empty()) scores[object->class_name] = object->probability * object->observations;
  scores[class_name] += score;
  const auto best =
      std::max_element(scores.begin(), scores.end(),
                       [](const auto& a, const auto& b) { return a.second < b.second; });
  if (best->first != object->class_name) {
    object->class_name = best->first;
    object->class_id = cocoClassId(best->first);
  }
}

}  // namespace object_database_detail

FusionKeys makeFusionKeys(const PointCloud& segment_W, const PointCloud& seen_W,
                          double voxel_size_m) {
  FusionKeys keys;
  keys.voxel_size_m = voxel_size_m;
  keys.cut = voxelKeys(segment_W, voxel_size_m);
  const std::vector<std::int64_t> seen = voxelKeys(seen_W, voxel_size_m);
  std::set_difference(seen.begin(), seen.end(), keys.cut.begin(), keys.cut.end(),
                      std::back_inserter(keys.outside));
  return keys;
}

bool ObjectDatabase::isSupported(const VoxelEvidence& e) const {
  if (!(e.inside >= 1 && e.inside >= e.outside)) return false;
  if (!(config_.surface_band_m > 0.0) || e.sdf_count == 0) return true;
  return std::abs(e.sdf_sum / e.sdf_count) <= config_.surface_band_m;
}

std::int64_t ObjectDatabase::voxelKey(const Eigen::Vector3f& p_W) const {
  return voxelKeyOf(p_W, config_.fusion_voxel_size_m);
}

Eigen::Vector3f ObjectDatabase::voxelCentre(std::int64_t key) const {
  return ((unpackVoxel(key).cast<double>().array() + 0.5) * config_.fusion_voxel_size_m)
      .matrix()
      .cast<float>();
}

PointCloud ObjectDatabase::supportedVoxels(const MapObject& object,
                                           std::vector<Eigen::Vector3f>* normals_W) const {
  // Packed voxel keys are non-negative (63 bits): their order as unsigned is their order.
  std::vector<std::pair<std::uint64_t, const VoxelEvidence*>> supported;
  supported.reserve(object.evidence.size());
  for (const auto& entry : object.evidence) {
    const VoxelEvidence& e = entry.second;
    if (isSupported(e)) supported.emplace_back(static_cast<std::uint64_t>(entry.first), &e);
  }
  // Hash order is not stable across library versions: key order for reproducible boxes.
  radixSortByKey(&supported);
  PointCloud centres;
  centres.reserve(supported.size());
  if (normals_W != nullptr) {
    normals_W->clear();
    normals_W->reserve(supported.size());
  }
  for (const auto& voxel : supported) {
    centres.push_back(voxelCentre(static_cast<std::int64_t>(voxel.first)));
    if (normals_W == nullptr) continue;
    const float norm = voxel.second->normal_sum.norm();
    if (norm > 1e-6f && std::isfinite(norm)) normals_W->push_back(voxel.second->normal_sum / norm);
  }
  return centres;
}

ObjectDatabase::FusionResult ObjectDatabase::fuseOrInsert(const ObjectObservation& observation,
                                                          const FusedCloudProcessor& process,
                                                          bool defer_rebox, int object_id) {
  beginKeyframe(observation.keyframe);
  FusionResult result;
  // Evidence fusion: the voxels of this view's cut and of what it saw around it, computed once
  // (by the single-view stage, or here).
  const bool evidence = config_.fusion == "evidence";
  const std::shared_ptr<const FusionKeys> keys = evidence ? fusionKeysOf(observation) : nullptr;
  MapObject* target = nullptr;
  bool nearest_searched = false;  // result.distance_m holds Eq. 6's min d_i
  if (config_.disable_fusion || object_id == -1) {
    target = nullptr;
  } else if (object_id >= 0) {
    const auto it = objects_.find(object_id);
    target = it != objects_.end() ? &it->second : nullptr;
  } else if (evidence) {
    const std::vector<Candidate> candidates = candidatesOf(observation, *keys);
    if (!candidates.empty()) target = candidates.front().object;
  } else {
    MapObject* nearest = nearestSameClass(observation, &result.distance_m);
    nearest_searched = true;
    if (nearest != nullptr && result.distance_m <= priors_.fusionDistance(observation.class_name)) {
      target = nearest;  // Eq. 6
    }
  }
  if (target != nullptr) {
    result.distance_m = (target->seenBox().center_m - observation.box.center_m).norm();
    if (evidence) {
      fused_this_keyframe_.push_back(target->id);
      fuseEvidence(observation, *keys, process, defer_rebox, target);
    } else {
      fusePaper(observation, process, target);
    }
    result.decision = Decision::kFused;
    result.object_id = target->id;
    return result;
  }
  // Inserted: how far the nearest object of its class is (Eq. 6's min d_i), before it joins them.
  if (!nearest_searched) nearestSameClass(observation, &result.distance_m);
  result.decision = Decision::kInserted;
  result.object_id = insert(observation, keys.get());
  return result;
}

void ObjectDatabase::beginKeyframe(int keyframe) {
  if (keyframe == current_keyframe_) return;
  current_keyframe_ = keyframe;
  inserted_this_keyframe_.clear();
  fused_this_keyframe_.clear();
}

bool ObjectDatabase::insertedThisKeyframe(const MapObject& object) const {
  // Sec. 3.4.1: two detections of one image are two objects.
  return config_.no_fusion_within_keyframe &&
         std::find(inserted_this_keyframe_.begin(), inserted_this_keyframe_.end(), object.id) !=
             inserted_this_keyframe_.end();
}

MapObject* ObjectDatabase::nearestSameClass(const ObjectObservation& observation,
                                            double* distance_m) {
  // Eq. 6: the nearest object of the same class, by box-centre distance.
  *distance_m = std::numeric_limits<double>::infinity();
  MapObject* nearest = nullptr;
  for (auto& entry : objects_) {
    MapObject& object = entry.second;
    if (object.class_name != observation.class_name || insertedThisKeyframe(object)) continue;
    // A completed box's centre lies in the part no view saw: the views' own box is matched.
    const double d = (object.seenBox().center_m - observation.box.center_m).norm();
    if (d < *distance_m) {
      *distance_m = d;
      nearest = &object;
    }
  }
  return nearest;
}

std::shared_ptr<const FusionKeys> ObjectDatabase::fusionKeysOf(
    const ObjectObservation& observation) const {
  std::shared_ptr<const FusionKeys> keys = observation.fusion_keys;
  if (keys == nullptr || keys->voxel_size_m != config_.fusion_voxel_size_m) {
    keys = std::make_shared<const FusionKeys>(
        makeFusionKeys(observation.segment_W, observation.seen_W, config_.fusion_voxel_size_m));
  }
  return keys;
}

void ObjectDatabase::addObservation(const ObjectObservation& observation, MapObject* object) {
  // Eq. 8 taken literally: the mean of the new and the stored probability (a running pairwise
  // mean, which weights recent views more than an average over all views would).
  object->probability = 0.5 * (observation.probability + object->probability);
  object->observations += 1;
  object->last_keyframe = observation.keyframe;
  object->last_seen_s = observation.stamp_s;
}

void ObjectDatabase::fuseEvidence(const ObjectObservation& observation, const FusionKeys& keys,
                                  const FusedCloudProcessor& process, bool defer_rebox,
                                  MapObject* object) {
  // The class: the largest summed probability of the detections fused here.
  addClassScore(observation.class_name, observation.probability, object);
  addObservation(observation, object);
  // A map saved before evidence fusion (or by the paper's fusion): its segment is the evidence.
  if (object->evidence_voxel_size_m != config_.fusion_voxel_size_m) object->evidence.clear();
  object->evidence_voxel_size_m = config_.fusion_voxel_size_m;
  if (object->evidence.empty()) {
    countInside(voxelKeys(object->segment_W, config_.fusion_voxel_size_m), &object->evidence);
  }
  addVotes(observation, keys, config_.fusion_voxel_size_m, &object->evidence);
  addViewBox(observation.box, object);
  if (defer_rebox) {
    deferRebox(*object, observation.depth_view);
    return;
  }
  if (observation.depth_view != nullptr && config_.surface_band_m > 0.0) {
    addSignedDistances(*observation.depth_view, config_.fusion_voxel_size_m, &object->evidence);
  }
  rebox(object, process, observation.depth_view.get());
}

void ObjectDatabase::addViewBox(const OrientedBox& box, MapObject* object) {
  if (object->view_boxes.size() >= kMaxViewBoxes) {
    object->view_boxes.erase(object->view_boxes.begin(),
                             object->view_boxes.end() - (kMaxViewBoxes - 1));
  }
  object->view_boxes.push_back(box);
}

void ObjectDatabase::deferRebox(const MapObject& object,
                                const std::shared_ptr<const DepthView>& depth_view) {
  const auto at = std::lower_bound(pending_rebox_.begin(), pending_rebox_.end(), object.id);
  if (at == pending_rebox_.end() || *at != object.id) pending_rebox_.insert(at, object.id);
  // The keyframe's signed distances (and free space) once per object, however many of its
  // detections fuse here, with the boxing (in parallel).
  if (depth_view != nullptr) pending_depth_views_[object.id] = depth_view;
}

void ObjectDatabase::fusePaper(const ObjectObservation& observation,
                               const FusedCloudProcessor& process, MapObject* object) const {
  addObservation(observation, object);
  // Eq. 7 on the unsegmented clouds; the voxel grid keeps repeated views of one surface bounded.
  PointCloud merged;
  merged.reserve(object->points_W.size() + observation.points_W.size());
  merged.insert(merged.end(), object->points_W.begin(), object->points_W.end());
  merged.insert(merged.end(), observation.points_W.begin(), observation.points_W.end());
  object->points_W = PointCloudFilter::voxelize(merged, config_.fusion_voxel_size_m);
  PointCloud segment_W;
  OrientedBox box;
  double yaw_rad = object->yaw_rad;
  if (process && process(object->class_name, object->points_W, {}, &segment_W, &box, &yaw_rad)) {
    object->segment_W = std::move(segment_W);
    object->box = box;
    object->yaw_rad = yaw_rad;
  }  // else: nothing usable in the fused cloud, the previous segment and box stay.
}

int ObjectDatabase::insert(const ObjectObservation& observation, const FusionKeys* keys) {
  MapObject object;
  object.id = takeNextId();
  object.class_id = observation.class_id;
  object.class_name = observation.class_name;
  object.probability = observation.probability;
  object.observations = 1;
  object.segment_W = observation.segment_W;
  if (keys != nullptr) {
    // Evidence fusion: the object is what the cut holds; its cloud is the voxels with evidence, as
    // after fusions (the outside votes find none of its voxels yet).
    object.class_scores[observation.class_name] = observation.probability;
    addVotes(observation, *keys, config_.fusion_voxel_size_m, &object.evidence);
    if (observation.depth_view != nullptr && config_.surface_band_m > 0.0) {
      addSignedDistances(*observation.depth_view, config_.fusion_voxel_size_m, &object.evidence);
    }
    object.evidence_voxel_size_m = config_.fusion_voxel_size_m;
    addViewBox(observation.box, &object);
    for (const auto& entry : object.evidence) object.points_W.push_back(voxelCentre(entry.first));
  } else {
    object.points_W = PointCloudFilter::voxelize(observation.points_W, config_.fusion_voxel_size_m);
  }
  object.box = observation.box;
  object.yaw_rad = observation.yaw_rad;
  if (keys != nullptr) completeBox(&object, observation.depth_view.get());
  object.first_keyframe = observation.keyframe;
  object.last_keyframe = observation.keyframe;
  object.first_seen_s = observation.stamp_s;
  object.last_seen_s = observation.stamp_s;
  inserted_this_keyframe_.push_back(object.id);
  const int id = object.id;
  objects_.emplace(id, std::move(object));
  return id;
}

const MapObject* ObjectDatabase::find(int id) const {
  const auto it = objects_.find(id);
  return it == objects_.end() ? nullptr : &it->second;
}

std::vector<const MapObject*> ObjectDatabase::findByClass(const std::string& class_name) const {
  std::vector<const MapObject*> found;
  for (const auto& entry : objects_) {
    if (entry.second.class_name == class_name) found.push_back(&entry.second);
  }
  return found;
}

bool ObjectDatabase::remove(int id, MapObject* taken) {
  pending_rebox_.erase(std::remove(pending_rebox_.begin(), pending_rebox_.end(), id),
                       pending_rebox_.end());
  pending_depth_views_.erase(id);
  inserted_this_keyframe_.erase(
      std::remove(inserted_this_keyframe_.begin(), inserted_this_keyframe_.end(), id),
      inserted_this_keyframe_.end());
  fused_this_keyframe_.erase(
      std::remove(fused_this_keyframe_.begin(), fused_this_keyframe_.end(), id),
      fused_this_keyframe_.end());
  const auto it = objects_.find(id);
  if (it == objects_.end()) return false;
  if (taken != nullptr) *taken = std::move(it->second);
  objects_.erase(it);
  return true;
}

void ObjectDatabase::clear() {
  objects_.clear();
  pending_rebox_.clear();
  pending_depth_views_.clear();
  inserted_this_keyframe_.clear();
  fused_this_keyframe_.clear();
  current_keyframe_ = -1;
}

Status ObjectDatabase::setObjects(const std::vector<MapObject>& objects) {
  std::map<int, MapObject> replaced;
  int largest_id = 0;
  for (const MapObject& object : objects) {
    if (object.id < 0 || object.id > kMaxObjectId) {
      return Status::Error("object id " + std::to_string(object.id) + " is outside [0, " +
                           std::to_string(kMaxObjectId) + "]");
    }
    if (!replaced.emplace(object.id, object).second) {
      return Status::Error("object id " + std::to_string(object.id) + " is repeated");
    }
    largest_id = std::max(largest_id, object.id);
  }
  clear();
  objects_ = std::move(replaced);
  next_id_ = std::max(next_id_, largest_id + 1);
  return Status::Ok();
}

int ObjectDatabase::takeNextId() {
  if (next_id_ <= kMaxObjectId) return next_id_++;
  // After a billion objects: the smallest id not in use (ids are reused only here).
  int id = 0;
  while (objects_.count(id) != 0) ++id;
  return id;
}

std::vector<int> ObjectDatabase::updateExistence(const DepthView* view,
                                                 const std::vector<int>& detected_ids) {
  std::vector<int> gone;
  if (!config_.existence.enable || config_.fusion != "evidence") return gone;
  const ExistenceModel model(config_.existence);
  for (auto& entry : objects_) {
    MapObject& object = entry.second;
    const bool detected =
        std::find(detected_ids.begin(), detected_ids.end(), object.id) != detected_ids.end();
    if (!detected && view == nullptr) continue;
    const ExistenceModel::Vote vote =
        detected ? ExistenceModel::Vote::kDetected
                 : model.vote(object.segment_W, object.seenBox(), *view, false);
    if (model.apply(vote, &object.existence, view)) gone.push_back(object.id);
  }
  return gone;
}

ExistenceModel::DepthCheck ObjectDatabase::checkDepth(const DepthView& view) const {
  ExistenceModel::DepthCheck check;
  const ExistenceModel model(config_.existence);
  for (const auto& entry : objects_) {
    const MapObject& object = entry.second;
    // A detection that has not repeated says little of the map (it may be what a fault made).
    if (object.existence.detected < ExistenceModel::kConfirmedDetections) continue;
    switch (model.vote(object.segment_W, object.seenBox(), view, false)) {
      case ExistenceModel::Vote::kMissed:
        ++check.on_surface;
        break;
      case ExistenceModel::Vote::kSeenThrough:
        ++check.seen_through;
        break;
      default:
        break;
    }
  }
  return check;
}

}  // namespace mvod
