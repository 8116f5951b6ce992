#include "multiview_object_detection/pipeline/object_database.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "multiview_object_detection/pipeline/point_cloud_filter.h"

namespace mvod {

Status ObjectDatabase::Config::isValid() const {
  if (!(std::isfinite(fusion_voxel_size_m) && fusion_voxel_size_m > 0.0)) {
    return Status::Error("fusion_voxel_size_m must be a finite value > 0 (got " +
                         std::to_string(fusion_voxel_size_m) + ")");
  }
  return Status::Ok();
}

std::string ObjectDatabase::Config::print() const {
  std::ostringstream out;
  out << "fusion_voxel_size_m: " << fusion_voxel_size_m << "\n"
      << "no_fusion_within_keyframe: " << (no_fusion_within_keyframe ? "true" : "false") << "\n"
      << "disable_fusion: " << (disable_fusion ? "true" : "false") << "\n";
  return out.str();
}

ObjectDatabase::FusionResult ObjectDatabase::fuseOrInsert(const ObjectObservation& observation,
                                                          const FusedCloudProcessor& process) {
  if (observation.keyframe != current_keyframe_) {
    current_keyframe_ = observation.keyframe;
    inserted_this_keyframe_.clear();
  }

  // Eq. 6: the nearest object of the same class, by box-centre distance.
  FusionResult result;
  result.distance_m = std::numeric_limits<double>::infinity();
  MapObject* nearest = nullptr;
  for (auto& entry : objects_) {
    MapObject& object = entry.second;
    if (object.class_name != observation.class_name) continue;
    if (config_.no_fusion_within_keyframe &&
        std::find(inserted_this_keyframe_.begin(), inserted_this_keyframe_.end(), object.id) !=
            inserted_this_keyframe_.end()) {
      continue;  // Sec. 3.4.1: two detections of one image are two objects.
    }
    const double d = (object.box.center_m - observation.box.center_m).norm();
    if (d < result.distance_m) {
      result.distance_m = d;
      nearest = &object;
    }
  }

  const double threshold_m = priors_.fusionDistance(observation.class_name);
  if (!config_.disable_fusion && nearest != nullptr && result.distance_m <= threshold_m) {
    MapObject& object = *nearest;
    // Eq. 7 on the unsegmented clouds; the voxel grid keeps repeated views of one surface bounded.
    PointCloud merged;
    merged.reserve(object.points_W.size() + observation.points_W.size());
    merged.insert(merged.end(), object.points_W.begin(), object.points_W.end());
    merged.insert(merged.end(), observation.points_W.begin(), observation.points_W.end());
    object.points_W = PointCloudFilter::voxelize(merged, config_.fusion_voxel_size_m);

    PointCloud segment_W;
    OrientedBox box;
    double yaw_rad = object.yaw_rad;
    if (process && process(object.points_W, &segment_W, &box, &yaw_rad)) {
      object.segment_W = std::move(segment_W);
      object.box = box;
      object.yaw_rad = yaw_rad;
    }  // else: nothing usable in the fused cloud, the previous segment and box stay.

    // Eq. 8 taken literally: the mean of the new and the stored probability (a running pairwise
    // mean, which weights recent views more than an average over all views would).
    object.probability = 0.5 * (observation.probability + object.probability);
    object.observations += 1;
    object.last_keyframe = observation.keyframe;
    object.last_seen_s = observation.stamp_s;

    result.decision = Decision::kFused;
    result.object_id = object.id;
    return result;
  }

  MapObject object;
  object.id = next_id_++;
  object.class_id = observation.class_id;
  object.class_name = observation.class_name;
  object.probability = observation.probability;
  object.observations = 1;
  object.points_W = PointCloudFilter::voxelize(observation.points_W, config_.fusion_voxel_size_m);
  object.segment_W = observation.segment_W;
  object.box = observation.box;
  object.yaw_rad = observation.yaw_rad;
  object.first_keyframe = observation.keyframe;
  object.last_keyframe = observation.keyframe;
  object.first_seen_s = observation.stamp_s;
  object.last_seen_s = observation.stamp_s;
  inserted_this_keyframe_.push_back(object.id);

  result.decision = Decision::kInserted;
  result.object_id = object.id;
  objects_.emplace(object.id, std::move(object));
  return result;
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

bool ObjectDatabase::remove(int id) {
  inserted_this_keyframe_.erase(
      std::remove(inserted_this_keyframe_.begin(), inserted_this_keyframe_.end(), id),
      inserted_this_keyframe_.end());
  return objects_.erase(id) > 0;
}

void ObjectDatabase::clear() {
  objects_.clear();
  inserted_this_keyframe_.clear();
  current_keyframe_ = -1;
}

void ObjectDatabase::setObjects(const std::vector<MapObject>& objects) {
  clear();
  int largest_id = 0;
  for (const MapObject& object : objects) {
    objects_[object.id] = object;
    largest_id = std::max(largest_id, object.id);
  }
  next_id_ = std::max(next_id_, largest_id + 1);
}

}  // namespace mvod
