// ObjectMapper's fusion and refinement (Sec. 3.4-3.5): a keyframe's single views into the object
// database, existence evidence, re-boxing fused objects, and Algorithm 1's refinement.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "multiview_object_detection/pipeline/object_mapper.h"
#include "multiview_object_detection/pipeline/utils/parallel.h"
#include "multiview_object_detection/pipeline/utils/stopwatch.h"
#include "object_mapper_detail.h"

namespace mvod {
namespace {

using Clock = StopwatchClock;
using object_mapper_detail::addStageTimes;
using object_mapper_detail::warnDetection;

}  // namespace

void ObjectMapper::fuseKeyframe(const RgbdFrame& frame, int keyframe, const KeptDetections& kept,
                                const std::string& label,
                                const std::shared_ptr<const DepthView>& depth_view,
                                std::vector<SingleView>* views, KeyframeReport* out) {
  // Eq. 5-8 in detection order: the same map whatever the thread count. Evidence fusion counts
  // each detection's votes in that order and boxes the objects that changed once, at the end of
  // the keyframe, in parallel.
  const bool defer_rebox = config_.database.fusion == "evidence";
  // Amodal completion grounds the boxes it completes on the floor, when that is known.
  database_.setFloorHeight(floorCutActive() ? floor_.floorHeight_m()
                                            : std::numeric_limits<double>::quiet_NaN());
  database_.setGravityUp(gravity().up);
  // A keyframe whose depth contradicts most of the map, or whose pose is upside down, is a fault:
  // its views are not fused (their clouds come from that depth and pose) and it does not vote.
  std::string why;
  out->depth_fault = isKeyframeFault(frame.T_W_D, depth_view.get(), &why);
  if (out->depth_fault) out->warnings.push_back(label + ": " + why);
  // The detections' fields, then the association of all of them at once, then the fusion.
  std::vector<const ObjectObservation*> observations;
  std::vector<size_t> observed;
  for (size_t k = 0; k < kept.detections.size(); ++k) {
    const Detection2D& detection = kept.detections[k];
    SingleView& view = (*views)[k];
    // Stage times are summed over detections (CPU time when they ran in parallel).
    addStageTimes(view.times, &out->times);
    out->times.largest_view_ms = std::max(out->times.largest_view_ms, view.wall_ms);
    if (!view.status) {
      warnDetection(label, kept.index[k], detection, view.status.message(), out);
      continue;
    }
    ObjectObservation& observation = view.observation;
    ++out->with_box;
    observation.class_id = detection.class_id;
    observation.class_name = detection.class_name;
    observation.probability = detection.score;
    observation.keyframe = keyframe;
    observation.stamp_s = frame.stamp_s;
    observation.depth_view = depth_view;
    if (out->depth_fault) continue;  // kept in the history: a correction may fuse it
    observations.push_back(&observation);
    observed.push_back(k);
  }
  const std::vector<int> object_ids = associateKeyframe(observations, &out->times);
  for (size_t n = 0; n < observed.size(); ++n) {
    const size_t k = observed[n];
    SingleView& view = (*views)[k];
    const ObjectDatabase::FusionResult result =
        fuseObservation(view.observation, defer_rebox, &out->times, object_ids[n]);
    view.object_id = result.object_id;
    if (kept.index[k] < out->object_ids.size()) {
      out->object_ids[kept.index[k]] = result.object_id;
    }
    if (result.decision == ObjectDatabase::Decision::kFused) {
      ++out->fused;
    } else {
      ++out->inserted;
    }
  }
  if (!database_.pendingRebox().empty()) reboxPending(&out->times);
  if (existenceActive() && !out->depth_fault) {
    std::vector<int> detected_ids;
    for (const SingleView& view : *views) {
      if (view.status && view.object_id >= 0) detected_ids.push_back(view.object_id);
    }
    const Clock::time_point t = Clock::now();
    updateExistence(depth_view.get(), detected_ids, &out->removed);
    out->times.existence_ms += msSince(t);
  }
}

bool ObjectMapper::isKeyframeFault(const Eigen::Isometry3d& T_W_D, const DepthView* view,
                                   std::string* why) const {
  // The image's "down" (the optical frame's y) pointing up: the camera is upside down relative to
  // gravity, and whatever it maps would lie upside down, below the floor (a wrong gravity_down,
  // or a pose flipped). More than 60 degrees from down: no robot or hand-held RGB-D camera looks
  // so; one mounted upside down has its images flipped by its driver.
  const double down_up = T_W_D.linear().col(1).dot(gravity().up);
  if (down_up > 0.5) {
    char text[320];
    std::snprintf(text, sizeof(text),
                  "the camera is upside down relative to gravity (its image's down points %.0f "
                  "degrees from up): a wrong gravity_down or a flipped pose? Objects mapped from "
                  "it would lie upside down, below the floor; it does not vote and its detections "
                  "are not fused",
                  std::acos(std::min(1.0, down_up)) * 180.0 / M_PI);
    *why = text;
    return true;
  }
  const ExistenceModel::DepthCheck check = checkKeyframeDepth(view);
  if (!ExistenceModel::isFault(check)) return false;
  *why = "its depth sees through " + std::to_string(check.seen_through) + " of the " +
         std::to_string(check.on_surface + check.seen_through) +
         " confirmed objects whose place it shows: taken for a sensor or SLAM fault (its depth or "
         "pose is wrong); it does not vote and its detections are not fused";
  return true;
}

ExistenceModel::DepthCheck ObjectMapper::checkKeyframeDepth(const DepthView* view) const {
  if (view == nullptr || !existenceActive()) return ExistenceModel::DepthCheck();
  return database_.checkDepth(*view);
}

void ObjectMapper::updateExistence(const DepthView* view, const std::vector<int>& detected_ids,
                                   std::vector<MapObject>* removed) {
  for (const int id : database_.updateExistence(view, detected_ids)) {
    if (removed != nullptr && database_.find(id) != nullptr)
      removed->push_back(*database_.find(id));
    database_.remove(id);
  }
}

std::vector<int> ObjectMapper::associateKeyframe(
    const std::vector<const ObjectObservation*>& observations, StageTimes* times) {
  const Clock::time_point t = Clock::now();
  std::vector<int> object_ids = database_.associate(observations);
  times->fusion_ms += msSince(t);
  return object_ids;
}

ObjectDatabase::FusionResult ObjectMapper::fuseObservation(const ObjectObservation& observation,
                                                           bool defer_rebox, StageTimes* times,
                                                           int object_id) {
  // Eq. 6-8; the fused cloud's filter/LCCP/box time counts in those stages and in fusion.
  const Clock::time_point t = Clock::now();
  StageTimes fused_times;
  const FusedCloudProcessor process =
      [this, &fused_times](const std::string& class_name, const PointCloud& points_W,
                           const std::vector<Eigen::Vector3f>& normals_W, PointCloud* segment_W,
                           OrientedBox* box, double* yaw_rad) {
        return processFused(class_name, points_W, normals_W, segment_W, box, yaw_rad, &fused_times);
      };
  const ObjectDatabase::FusionResult result =
      database_.fuseOrInsert(observation, process, defer_rebox, object_id);
  times->fusion_ms += msSince(t);
  addStageTimes(fused_times, times);
  return result;
}

void ObjectMapper::reboxPending(StageTimes* times) {
  const Clock::time_point t = Clock::now();
  std::mutex times_mutex;
  StageTimes rebox_times;
  const FusedCloudProcessor rebox = [this, &rebox_times, &times_mutex](
                                        const std::string& class_name, const PointCloud& points_W,
                                        const std::vector<Eigen::Vector3f>& normals_W,
                                        PointCloud* segment_W, OrientedBox* box, double* yaw_rad) {
    StageTimes object_times;
    const bool ok =
        processFused(class_name, points_W, normals_W, segment_W, box, yaw_rad, &object_times);
    const std::lock_guard<std::mutex> lock(times_mutex);
    addStageTimes(object_times, &rebox_times);
    return ok;
  };
  database_.reboxPending(rebox, threadCount());
  times->fusion_ms += msSince(t);
  addStageTimes(rebox_times, times);
}

bool ObjectMapper::processFused(const std::string& class_name, const PointCloud& points_W,
                                const std::vector<Eigen::Vector3f>& normals_W,
                                PointCloud* segment_W, OrientedBox* box, double* yaw_rad,
                                StageTimes* times) const {
  Clock::time_point t;
  if (config_.database.fusion == "evidence") {
    // The supported voxels are the object: box them (robust extents, grounded), nothing else. The
    // yaw comes from the normals the views left in the voxels; a map saved before they were kept
    // (too few of them) has its normals estimated once more.
    t = Clock::now();
    const GravityFrame gravity_frame = gravity();
    // A flat top: what single views let through above it (the cups on a table, in a view whose
    // top was estimated higher) goes here too.
    PointCloud below_top_W;
    const PointCloud& object_W = clipAboveFlatTop(class_name, points_W, gravity_frame, &below_top_W)
                                     ? below_top_W
                                     : points_W;
    OrientedBox fused_box;
    const bool kept_normals = normals_W.size() >= 1000 || normals_W.size() * 8 >= points_W.size();
    const Status boxed =
        kept_normals
            ? box_estimator_.estimateFromNormals(object_W, normals_W, gravity_frame, &fused_box)
            : box_estimator_.estimate(object_W, gravity_frame, &fused_box);
    if (!boxed) return false;
    groundBox(class_name, &fused_box);
    times->manhattan_ms += msSince(t);
    *segment_W = object_W;
    *box = fused_box;
    *yaw_rad = gravity_frame.yawOf(fused_box.rotation.col(0));
    return true;
  }
  // Eq. 7's fused cloud goes through the same filter, LCCP and box stages, in the world frame.
  t = Clock::now();
  // points_W comes from the database, already on its fusion grid: no second voxel pass.
  const PointCloud filtered_W =
      config_.filter.enable ? filter_.filterFused(points_W, config_.database.fusion_voxel_size_m)
                            : points_W;
  times->filter_ms += msSince(t);
  if (static_cast<int>(filtered_W.size()) < config_.min_object_points) return false;

  t = Clock::now();
  LccpSegmenter::Result segmentation;
  const Status segmented = lccp_.segment(filtered_W, false, &segmentation);
  times->lccp_ms += msSince(t);
  if (!segmented || segmentation.largest_segment.empty()) return false;

  t = Clock::now();
  const GravityFrame gravity_frame = gravity();
  OrientedBox fused_box;
  const Status boxed =
      box_estimator_.estimate(segmentation.largest_segment, gravity_frame, &fused_box);
  times->manhattan_ms += msSince(t);
  if (!boxed) return false;

  *segment_W = std::move(segmentation.largest_segment);
  *box = fused_box;
  *yaw_rad = gravity_frame.yawOf(fused_box.rotation.col(0));
  return true;
}

ObjectMapper::RefinementReport ObjectMapper::refine() {
  refined_ = true;
  if (!history_.empty()) history_.mutableRecords().back().refined_after = true;
  const RefinementReport report = refineDatabase();
  // A merged duplicate's views are the kept object's now.
  for (const auto& merged : report.merged_ids) {
    for (KeyframeRecord& record : history_.mutableRecords()) {
      for (RecordedView& view : record.views) {
        if (view.object_id == merged.first) view.object_id = merged.second;
      }
    }
  }
  return report;
}

ObjectMapper::RefinementReport ObjectMapper::refineDatabase() {
  const Clock::time_point start = Clock::now();
  RefinementReport report;
  // Sec. 3.5.1 first; Algorithm 1 then only sees the survivors.
  if (config_.prior_filter.enable) {
    std::vector<PriorSizeFilter::Verdict> verdicts;
    report.atypical_ids =
        prior_filter_.atypicalObjects(database_, &verdicts, &report.atypical_reasons);
    report.atypical_too_large = static_cast<int>(
        std::count(verdicts.begin(), verdicts.end(), PriorSizeFilter::Verdict::kTooLarge));
    for (size_t k = 0; k < report.atypical_ids.size(); ++k) {
      RemovedObject removed;
      if (!database_.remove(report.atypical_ids[k], &removed.object)) continue;
      removed.reason = k < report.atypical_reasons.size() ? report.atypical_reasons[k]
                                                          : "atypical size for its class (Eq. 9)";
      report.removed.push_back(std::move(removed));
    }
  }
  if (config_.intersection_filter.enable) {
    std::vector<std::pair<int, int>> duplicates;
    report.intersecting_ids =
        intersection_filter_.intersectingObjects(database_, gravity().up, &duplicates);
    // Not in the single-frame baseline (Table 2): that would be fusion after all.
    if (config_.intersection_filter.merge_duplicates && config_.database.fusion == "evidence" &&
        !config_.database.disable_fusion) {
      const std::set<int> deleted(report.intersecting_ids.begin(), report.intersecting_ids.end());
      StageTimes times;
      const FusedCloudProcessor process =
          [this, &times](const std::string& class_name, const PointCloud& points_W,
                         const std::vector<Eigen::Vector3f>& normals_W, PointCloud* segment_W,
                         OrientedBox* box, double* yaw_rad) {
            return processFused(class_name, points_W, normals_W, segment_W, box, yaw_rad, &times);
          };
      for (const auto& duplicate : duplicates) {
        // Into an object that stays only (a chain: what it was merged into may go too).
        if (deleted.count(duplicate.second) != 0) continue;
        const MapObject* from = database_.find(duplicate.first);
        if (from == nullptr) continue;
        RemovedObject removed{
            *from, "a duplicate, merged into #" + std::to_string(duplicate.second)};  // as it was
        if (database_.mergeInto(duplicate.second, duplicate.first, process)) {
          report.merged_ids.push_back(duplicate);
          report.removed.push_back(std::move(removed));
        }
      }
    }
    for (const int id : report.intersecting_ids) {
      RemovedObject removed;
      if (!database_.remove(id, &removed.object)) continue;  // merged above
      removed.reason = "mostly inside another object (Eq. 10, 11)";
      report.removed.push_back(std::move(removed));
    }
  }
  report.time_ms = msSince(start);
  return report;
}

}  // namespace mvod
