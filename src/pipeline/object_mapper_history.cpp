// ObjectMapper's keyframe history: what each keyframe contributed, recorded after its fusion, and
// the map rebuilt from it when the SLAM corrects keyframe poses (keyframe_history.h).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <set>
#include <utility>

#include "multiview_object_detection/pipeline/object_mapper.h"
#include "multiview_object_detection/pipeline/types/map_limits.h"
#include "multiview_object_detection/pipeline/utils/parallel.h"
#include "multiview_object_detection/pipeline/utils/stopwatch.h"

namespace mvod {
namespace {

using Clock = StopwatchClock;

bool isRigid(const PoseCorrection& correction) {
  return std::isfinite(correction.stamp_s) && isValidPose(correction.T_W_C, 1e-3);
}

}  // namespace

void ObjectMapper::recordKeyframe(const RgbdFrame& frame, int keyframe, double floor_layer_m,
                                  bool depth_fault, std::vector<SingleView>* views) {
  if (!config_.corrections.enable || config_.database.fusion != "evidence") return;
  KeyframeRecord record;
  record.keyframe = keyframe;
  record.stamp_s = frame.stamp_s;
  record.name = frame.name;
  record.T_W_D_recorded = frame.T_W_D;
  record.T_W_D = frame.T_W_D;
  record.T_C_D = frame.T_C_D;
  record.K_depth = frame.K_depth;
  record.depth = frame.depth.clone();
  if (std::isfinite(floor_layer_m)) {
    // The floor below the camera: its height follows the keyframe's pose.
    const Eigen::Vector3d up = gravity().up;
    const Eigen::Vector3d camera_W = frame.T_W_D.translation();
    const Eigen::Vector3d floor_W = camera_W - (up.dot(camera_W) - floor_layer_m) * up;
    record.has_floor = true;
    record.floor_point_D = frame.T_W_D.inverse() * floor_W;
  }
  for (SingleView& view : *views) {
    if (!view.status || (view.object_id < 0 && !depth_fault)) continue;
    ObjectObservation& observation = view.observation;
    RecordedView recorded;
    recorded.class_id = observation.class_id;
    recorded.class_name = observation.class_name;
    recorded.probability = observation.probability;
    std::shared_ptr<const FusionKeys> keys = observation.fusion_keys;
    if (keys == nullptr || keys->voxel_size_m != config_.database.fusion_voxel_size_m) {
      keys = std::make_shared<const FusionKeys>(makeFusionKeys(
          observation.segment_W, observation.seen_W, config_.database.fusion_voxel_size_m));
    }
    auto cut = std::make_shared<RecordedCut>();
    cut->outside_keys = keys->outside;
    cut->voxel_size_m = keys->voxel_size_m;
    // The fusion is done with the observation: its cut moves into the history.
    cut->cut_W = std::move(observation.segment_W);
    cut->normals_W = std::move(observation.segment_normals_W);
    recorded.cut = std::move(cut);
    recorded.box = observation.box;
    recorded.yaw_rad = observation.yaw_rad;
    recorded.object_id = view.object_id;
    record.views.push_back(std::move(recorded));
  }
  history_.add(std::move(record));
}

void ObjectMapper::setHistory(std::deque<KeyframeRecord> records) {
  history_.clear();
  for (KeyframeRecord& record : records) history_.add(std::move(record));
  keyframes_ = std::max(keyframes_, history_.empty() ? 0 : history_.records().back().keyframe + 1);
}

Status ObjectMapper::correctPoses(const std::vector<PoseCorrection>& corrections,
                                  CorrectionReport* out) {
  const Clock::time_point start = Clock::now();
  CorrectionReport local;
  CorrectionReport& report = out != nullptr ? *out : local;
  report = CorrectionReport();
  for (std::size_t i = 0; i < corrections.size(); ++i) {
    if (!isRigid(corrections[i])) {
      return Status::Error("correction " + std::to_string(i) + " (stamp " +
                           std::to_string(corrections[i].stamp_s) +
                           ") is not a finite rigid transform; no correction applied");
    }
    const Status in_map =
        checkCameraInMap(corrections[i].T_W_C, "correction " + std::to_string(i) + " (stamp " +
                                                   std::to_string(corrections[i].stamp_s) + ")");
    if (!in_map) return Status::Error(in_map.message() + "; no correction applied");
  }
  report.objects_before = static_cast<int>(database_.size());
  if (!config_.corrections.enable || config_.database.fusion != "evidence") {
    report.ignored = true;
    report.objects_after = report.objects_before;
    return Status::Ok();
  }
  std::vector<PoseCorrection> unmatched;
  const std::vector<std::size_t> moved = history_.correct(corrections, &unmatched);
  report.unmatched = static_cast<int>(unmatched.size());
  report.keyframes_moved = static_cast<int>(moved.size());
  if (!moved.empty()) {
    rebuildFromHistory(moved, &report);
    for (RemovedObject& removed : report.removed) {
      removed.reason = "pose correction: " + removed.reason + " at the corrected poses";
    }
  }
  report.objects_after = static_cast<int>(database_.size());
  report.time_ms = msSince(start);
  return Status::Ok();
}

void ObjectMapper::fuseAgainAtNewGrid(ReconfigureReport* report) {
  const Clock::time_point start = Clock::now();
  report->objects_before = static_cast<int>(database_.size());
  report->objects_after = report->objects_before;
  if (!config_.corrections.enable || config_.database.fusion != "evidence" || history_.empty()) {
    report->next_fusions_only = true;
    return;
  }
  // Every view's voxels change: every keyframe counts as moved (what goes, the new grid explains).
  std::vector<std::size_t> all(history_.records().size());
  std::iota(all.begin(), all.end(), std::size_t{0});
  CorrectionReport rebuilt;
  rebuildFromHistory(all, &rebuilt);
  report->fused_again = true;
  for (RemovedObject& removed : rebuilt.removed) {
    char grid[64];
    std::snprintf(grid, sizeof(grid), "fused again at database/fusion_voxel_size_m %g m: ",
                  config_.database.fusion_voxel_size_m);
    removed.reason = grid + removed.reason;
    report->removed.push_back(std::move(removed));
  }
  report->objects_after = static_cast<int>(database_.size());
  report->time_ms = msSince(start);
}

void ObjectMapper::alignReplayedBox(const KeyframeRecord& record,
                                    ObjectObservation* observation) const {
  if (!record.corrected()) return;
  // A correction that tilts the keyframe tilts its boxes: the box is estimated again from the
  // moved cut and its normals, as the single view would have with this pose.
  const GravityFrame gravity_frame = gravity();
  if (observation->box.rotation.col(2).dot(gravity_frame.up) < 0.999) {
    OrientedBox box;
    if (box_estimator_
            .estimateFromNormals(observation->segment_W, observation->segment_normals_W,
                                 gravity_frame, &box)
            .ok()) {
      groundBox(observation->class_name, &box);
      observation->box = box;
    }
  }
  observation->yaw_rad = gravity_frame.yawOf(observation->box.rotation.col(0));
}

void ObjectMapper::rebuildFromHistory(const std::vector<std::size_t>& moved,
                                      CorrectionReport* report) {
  ObjectDatabase previous = std::move(database_);
  database_ = ObjectDatabase(config_.database, previous.priors());
  database_.setGravityUp(gravity().up);
  // The floor as the keyframes saw it so far, at their current poses (the single views' floor).
  floor_.reset();
  ReplayOutcome outcome;
  // The replay is sequential (each record fuses into the map the records before it made); what
  // the next record's replay needs of that record alone is prepared beside it.
  const std::deque<KeyframeRecord>& records = history_.records();
  // The refinement where it ran (a history loaded from an older map file says not where: then
  // once at the end, if it ran at all).
  const bool refined_where_recorded =
      std::any_of(records.begin(), records.end(),
                  [](const KeyframeRecord& record) { return record.refined_after; });
  ReplayInput next;
  if (!records.empty()) next = prepareReplay(records.front());
  for (std::size_t i = 0; i < records.size(); ++i) {
    ReplayInput input = std::move(next);
    next = ReplayInput();
    parallelInvoke(
        threadCount(), [&] { replayRecord(records[i], &input, &outcome, report); },
        [&] {
          if (i + 1 < records.size()) next = prepareReplay(records[i + 1]);
        });
    if (records[i].refined_after) refineRebuilt(&outcome);
  }
  if (refined_ && !refined_where_recorded) refineRebuilt(&outcome);
  std::vector<bool> moved_record(records.size(), false);
  for (const std::size_t index : moved) moved_record[index] = true;
  adoptRebuiltIds(&previous, outcome, moved_record, report);
}

void ObjectMapper::refineRebuilt(ReplayOutcome* outcome) {
  const RefinementReport refinement = refineDatabase();
  for (const auto& merged : refinement.merged_ids) {
    std::replace(outcome->rebuilt_ids.begin(), outcome->rebuilt_ids.end(), merged.first,
                 merged.second);
  }
  outcome->refined_ids.insert(refinement.atypical_ids.begin(), refinement.atypical_ids.end());
  outcome->refined_ids.insert(refinement.intersecting_ids.begin(),
                              refinement.intersecting_ids.end());
}

ObjectMapper::ReplayInput ObjectMapper::prepareReplay(const KeyframeRecord& record) const {
  ReplayInput input;
  const bool measure = (config_.database.surface_band_m > 0.0 || config_.database.amodal.enable) &&
                       !record.views.empty();
  if ((measure || existenceActive()) && !record.depth.empty()) {
    input.depth_view = makeDepthView(record.depth, record.K_depth, record.T_W_D);
  }
  input.observations.reserve(record.views.size());
  for (const RecordedView& view : record.views) {
    input.observations.push_back(
        replayedObservation(view, record.correction(), config_.database.fusion_voxel_size_m));
    input.observations.back().keyframe = record.keyframe;
    input.observations.back().stamp_s = record.stamp_s;
    input.observations.back().depth_view = input.depth_view;
  }
  return input;
}

void ObjectMapper::replayRecord(const KeyframeRecord& record, ReplayInput* input,
                                ReplayOutcome* outcome, CorrectionReport* report) {
  if (config_.floor.enable && record.has_floor) {
    const Eigen::Vector3d up = gravity().up;
    const double height_m = up.dot(record.T_W_D * record.floor_point_D);
    if (!floor_.hasFloor() || height_m < floor_.floorHeight_m()) floor_.setFloor(height_m, up);
  }
  if (record.views.empty() && !existenceActive()) return;
  database_.setFloorHeight(floorCutActive() ? floor_.floorHeight_m()
                                            : std::numeric_limits<double>::quiet_NaN());
  // A fault at its (corrected) pose, as when it was made: neither fused nor voting.
  std::string why;
  if (isKeyframeFault(record.T_W_D, input->depth_view.get(), &why)) {
    outcome->rebuilt_ids.insert(outcome->rebuilt_ids.end(), input->observations.size(), -1);
    return;
  }
  StageTimes times;
  std::vector<int> detected_ids;
  std::vector<const ObjectObservation*> observations;
  for (ObjectObservation& observation : input->observations) {
    alignReplayedBox(record, &observation);  // the floor as the records before it left it
    observations.push_back(&observation);
  }
  const std::vector<int> object_ids = associateKeyframe(observations, &times);
  for (size_t k = 0; k < observations.size(); ++k) {
    const ObjectObservation& observation = *observations[k];
    detected_ids.push_back(fuseObservation(observation, true, &times, object_ids[k]).object_id);
    outcome->rebuilt_ids.push_back(detected_ids.back());
    ++report->views_replayed;
  }
  if (!database_.pendingRebox().empty()) reboxPending(&times);
  if (existenceActive()) {
    std::vector<MapObject> gone;
    updateExistence(input->depth_view.get(), detected_ids, &gone);
    for (const MapObject& object : gone) outcome->gone_ids.insert(object.id);
  }
}

void ObjectMapper::adoptRebuiltIds(ObjectDatabase* previous, const ReplayOutcome& outcome,
                                   const std::vector<bool>& moved_record,
                                   CorrectionReport* report) {
  const std::vector<int>& rebuilt_ids = outcome.rebuilt_ids;
  // Each rebuilt object's views, and the ids they had.
  std::map<int, int> support;
  std::map<int, std::map<int, int>> votes;
  std::set<int> referenced;
  std::size_t k = 0;
  for (const KeyframeRecord& record : history_.records()) {
    for (const RecordedView& view : record.views) {
      const int rebuilt = rebuilt_ids[k++];
      if (view.object_id >= 0) referenced.insert(view.object_id);
      if (database_.find(rebuilt) == nullptr) continue;  // refined away
      ++support[rebuilt];
      if (view.object_id >= 0) ++votes[rebuilt][view.object_id];
    }
  }
  // The better supported objects choose first; each takes its views' most frequent id.
  std::vector<int> order;
  for (const auto& entry : database_.objects()) order.push_back(entry.first);
  std::stable_sort(order.begin(), order.end(),
                   [&support](int a, int b) { return support[a] > support[b]; });
  std::map<int, int> final_id;
  std::set<int> taken;
  int next_id = previous->nextId();
  for (const int rebuilt : order) {
    int best = -1;
    int best_votes = 0;
    for (const auto& vote : votes[rebuilt]) {
      if (taken.count(vote.first) == 0 && vote.second > best_votes) {
        best = vote.first;
        best_votes = vote.second;
      }
    }
    final_id[rebuilt] = best >= 0 ? best : next_id++;
    taken.insert(final_id[rebuilt]);
  }
  std::set<int> restore;
  explainRemoved(*previous, outcome, moved_record, final_id, &restore, report);
  std::vector<MapObject> objects;
  objects.reserve(database_.size());
  for (const auto& entry : database_.objects()) {
    MapObject object = entry.second;
    object.id = final_id[entry.first];
    objects.push_back(std::move(object));
  }
  for (const auto& entry : previous->objects()) {
    // Objects no view made (a map loaded from a file without history) cannot move: kept as they
    // are; so are those whose removal no moved keyframe explains.
    if (restore.count(entry.first) != 0) {
      objects.push_back(entry.second);
      continue;
    }
    if (referenced.count(entry.first) != 0 || taken.count(entry.first) != 0) continue;
    objects.push_back(entry.second);
    ++report->objects_kept_unmoved;
  }
  database_.setObjects(objects);
  database_.reserveIdsBelow(std::max(next_id, previous->nextId()));
  k = 0;
  for (KeyframeRecord& record : history_.mutableRecords()) {
    for (RecordedView& view : record.views) {
      const int rebuilt = rebuilt_ids[k++];
      if (restore.count(view.object_id) != 0) continue;  // the object kept as it was
      const auto it = final_id.find(rebuilt);
      if (it != final_id.end()) view.object_id = it->second;  // else refined away: keeps its id
    }
  }
}

void ObjectMapper::explainRemoved(const ObjectDatabase& previous, const ReplayOutcome& outcome,
                                  const std::vector<bool>& moved_record,
                                  const std::map<int, int>& final_id, std::set<int>* restore,
                                  CorrectionReport* report) const {
  // Per object of the previous map: whether a view of it moved, and what its views became; per
  // rebuilt object: whether a view of it moved.
  std::map<int, bool> object_moved;
  std::map<int, std::set<int>> became;
  std::set<int> rebuilt_moved;
  std::size_t k = 0;
  const std::deque<KeyframeRecord>& records = history_.records();
  for (std::size_t r = 0; r < records.size(); ++r) {
    for (const RecordedView& view : records[r].views) {
      const int rebuilt = outcome.rebuilt_ids[k++];
      if (moved_record[r]) rebuilt_moved.insert(rebuilt);
      if (view.object_id < 0) continue;
      object_moved[view.object_id] = object_moved[view.object_id] || moved_record[r];
      became[view.object_id].insert(rebuilt);
    }
  }
  std::set<int> kept;
  for (const auto& entry : final_id) kept.insert(entry.second);
  for (const auto& entry : previous.objects()) {
    const int id = entry.first;
    if (kept.count(id) != 0 || became.count(id) == 0) continue;  // still there, or has no views
    // Fused into another object, seen gone, or refined away at the corrected poses.
    int fused_into = -1;
    bool into_moved = false;
    bool gone = false;
    for (const int rebuilt : became[id]) {
      const auto it = final_id.find(rebuilt);
      if (it != final_id.end()) {
        fused_into = it->second;
        into_moved = into_moved || rebuilt_moved.count(rebuilt) != 0;
      }
      gone = gone || outcome.gone_ids.count(rebuilt) != 0;
    }
    if (!object_moved[id] && !into_moved) {
      restore->insert(id);
      ++report->objects_restored;
      continue;
    }
    RemovedObject removed;
    removed.object = entry.second;
    if (fused_into >= 0) {
      removed.reason =
          "fused into #" + std::to_string(fused_into) + ", which its views now overlap";
    } else if (gone) {
      removed.reason = "the keyframes' depth sees through its place";
      ++report->objects_gone;
    } else {
      removed.reason = "removed by the refinement (an atypical size, or inside another object)";
    }
    report->removed.push_back(std::move(removed));
  }
}

}  // namespace mvod
