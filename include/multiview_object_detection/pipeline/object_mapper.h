// The whole per-keyframe pipeline (Sec. 3.1-3.5) behind one class: the offline runner, the ROS node
// and the tests all drive it.
#pragma once

#include <atomic>
#include <deque>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "multiview_object_detection/pipeline/map/keyframe_history.h"
#include "multiview_object_detection/pipeline/map/object_database.h"
#include "multiview_object_detection/pipeline/map/refinement.h"
#include "multiview_object_detection/pipeline/stages/box_estimator.h"
#include "multiview_object_detection/pipeline/stages/floor_estimator.h"
#include "multiview_object_detection/pipeline/stages/gravity_estimator.h"
#include "multiview_object_detection/pipeline/stages/lccp_segmenter.h"
#include "multiview_object_detection/pipeline/stages/object_cloud_extractor.h"
#include "multiview_object_detection/pipeline/stages/point_cloud_filter.h"
#include "multiview_object_detection/pipeline/stages/segment_selector.h"

namespace mvod {

// Wall-clock time of each stage (ms), the split of the paper's Table 5.
struct StageTimes {
  double extraction_ms = 0.0;
  double filter_ms = 0.0;
  double lccp_ms = 0.0;
  double manhattan_ms = 0.0;
  double fusion_ms = 0.0;
  double existence_ms = 0.0;  // every object's existence vote from the keyframe's depth
  // Not a sum: the wall time of the keyframe's slowest single view (one detection's floor cut,
  // filter, LCCP, selection, box and evidence keys). With more than one thread the detections run
  // side by side, and this one is the keyframe's critical path between extraction and fusion.
  double largest_view_ms = 0.0;
  double refinement_ms = 0.0;
  double total_ms = 0.0;
};

// What happened to one keyframe (Table 4's counts, per keyframe).
struct KeyframeReport {
  int detections = 0;       // given to processKeyframe
  int above_threshold = 0;  // ψ >= λ (Eq. 5)
  int with_box = 0;         // survived extraction, filters, LCCP and got a box
  int inserted = 0;
  int fused = 0;
  // Per detection given (in order): the map object it was fused into or inserted as; -1 when it
  // was not mapped (under λ, no box). An id the existence evidence removed is still named.
  std::vector<int> object_ids;
  // Per detection given (in order): why it was not mapped, the problem as its warning states it
  // ("score under min_probability" below λ); empty where it was mapped, or where nothing was said.
  std::vector<std::string> drop_reasons;
  bool waiting_for_gravity = false;  // detections skipped: no gravity estimate yet
  // The keyframe's depth saw through most of the mapped objects it could see: a sensor or SLAM
  // fault (ExistenceModel::isFault). It did not vote and its detections were not fused; a warning
  // says so.
  bool depth_fault = false;  // also: its pose upside down relative to gravity
  // Objects this keyframe's votes showed gone (existence evidence), as they were; removed.
  std::vector<MapObject> removed;
  std::vector<std::string>
      warnings;  // per-detection problems (empty mask, no depth, unknown class ...)
  StageTimes times;
};

class ObjectMapper {
 public:
  // A detection's cloud with at least this many points has its selection masks (mask, core,
  // ring: a few milliseconds of erosion for ~100 000 pixels) computed as a job of their own on the
  // pool beside its filter and LCCP, when num_threads allows more than one; the same masks either
  // way.
  static constexpr size_t kMinPointsForMasksThread = 20000;

  struct Config {
    double min_probability = 0.5;  // λ
    // World gravity, pointing down. Zero vector = estimate it from the data (GravityEstimator).
    Eigen::Vector3d gravity_down_W = Eigen::Vector3d(0, 0, -1);
    int min_object_points = 50;  // fewer points after filtering: the detection is dropped
    // Threads for a keyframe's detections (floor cut, filter, LCCP, selection, box); 0 = one per
    // core. The database is updated in detection order afterwards and every stage is independent
    // of memory addresses (LccpSegmenter::groupSupervoxels), so the map is the same for any count.
    int num_threads = 0;
    ObjectCloudExtractor::Config extractor;
    PointCloudFilter::Config filter;
    LccpSegmenter::Config lccp;
    SegmentSelector::Config selection;  // which LCCP segments are the object
    FloorEstimator::Config floor;       // floor cut before LCCP, boxes grounded on the floor
    BoxEstimator::Config box;
    ObjectDatabase::Config database;
    PriorSizeFilter::Config prior_filter;
    IntersectionFilter::Config intersection_filter;
    GravityEstimator::Config gravity;
    // What each keyframe contributed, kept so that the map follows the SLAM's corrections
    // (correctPoses). Evidence fusion only.
    KeyframeHistory::Config corrections;
    Status isValid() const;  // checks every sub-config
    std::string print() const;
    // The paper's method as published: Eq. 2's largest segment, Eq. 7's literal fusion, min/max
    // extents, no floor cut. The defaults are what measured best (README, Evaluation).
    void usePaperMethod();
  };

  // An object of the map that a correction, a new fusion grid or the refinement took out, as it
  // was, and why (in the user's words).
  struct RemovedObject {
    MapObject object;
    std::string reason;
  };

  struct RefinementReport {
    std::vector<int> atypical_ids;
    // Per atypical_ids: why, in a user's words (PriorSizeFilter::judge); and how many were too
    // large (the others too small or thin, or of no valid size).
    std::vector<std::string> atypical_reasons;
    int atypical_too_large = 0;
    std::vector<int> intersecting_ids;
    // Of intersecting_ids: the duplicates merged into another object (merge_duplicates), as
    // (deleted id, id merged into).
    std::vector<std::pair<int, int>> merged_ids;
    // Every object removed (atypical ones, merged duplicates, the other intersecting ones), as it
    // was before the refinement, with why (the atypical reason; "a duplicate, merged into #N";
    // "mostly inside another object (Eq. 10, 11)"), for those who follow the map (the node's
    // ~removed_objects).
    std::vector<RemovedObject> removed;
    double time_ms = 0.0;
  };

  // What one correctPoses() did.
  struct CorrectionReport {
    bool ignored = false;     // the paper's method, or corrections off: nothing changes
    int keyframes_moved = 0;  // keyframes whose pose changed
    int unmatched = 0;        // corrections whose stamp matched no keyframe
    int views_replayed = 0;   // detections fused again
    int objects_before = 0;
    int objects_after = 0;
    int objects_kept_unmoved = 0;  // objects without recorded views (e.g. from an older map file)
    // Of removed: those the existence evidence showed gone at the corrected poses.
    int objects_gone = 0;
    // Objects of the map before that the rebuilt map no longer holds. Only objects with a view
    // in a moved keyframe, or fused into an object with one, can go: the moved poses explain it.
    std::vector<RemovedObject> removed;
    // Objects the rebuild would have removed although none of their views moved (nor those of
    // what they were fused into): kept as they were.
    int objects_restored = 0;
    double time_ms = 0.0;
  };

  ObjectMapper(const Config& config, const ClassPriors& priors);
  const Config& config() const { return config_; }
  // What updateConfig did to the map. A new fusion grid (database/fusion_voxel_size_m) changes what
  // the objects' evidence is counted on: with a keyframe history (evidence fusion) the map is fused
  // again from it at the new grid, as if that grid had been used from the start (the same
  // keyframes, views and ids; objects that now coincide become one). Without one (the paper's
  // method, corrections/enable false) the new grid applies to the next fusions only: each object
  // moves to it when a detection is next fused into it.
  struct ReconfigureReport {
    bool fused_again = false;
    bool next_fusions_only = false;  // the grid changed and there was no history to fuse from
    int objects_before = 0;
    int objects_after = 0;
    std::vector<RemovedObject> removed;  // objects the new grid fused into others or removed
    double time_ms = 0.0;
  };

  // Replaces the configuration at run time (the ROS node's dynamic reconfigure, gravity from TF):
  // the stage objects are rebuilt, the database keeps its objects and ids (fused again from the
  // history when the fusion grid changes: ReconfigureReport), the gravity estimator keeps its
  // state (new gravity settings apply from the next reset()). An invalid config returns the
  // isValid() error and changes nothing.
  Status updateConfig(const Config& config, ReconfigureReport* report = nullptr);

  // Runs Sec. 3.1-3.4 on one keyframe and its detections. A bad frame returns an error and changes
  // nothing; problems with single detections are warnings in the report. Warnings name the frame.
  // Until gravity is known (configured or estimated) detections are skipped with a "waiting for
  // gravity" warning.
  Status processKeyframe(const RgbdFrame& frame, const std::vector<Detection2D>& detections,
                         KeyframeReport* report);
  // Sec. 3.5: removes atypical and intersecting objects from the database.
  RefinementReport refine();

  // The SLAM corrected keyframe poses (a loop closure, a global bundle adjustment): every keyframe
  // a correction names (by stamp) takes its new pose, and the map is rebuilt from the recorded
  // views at their keyframes' current poses, in keyframe order, as if these poses had been known
  // from the start: objects move, re-fuse, and those that now coincide become one (keeping the id
  // most of its views had). The refinement runs again if it ran before. Keyframes not named keep
  // their pose. The paper's method keeps no history: report->ignored.
  Status correctPoses(const std::vector<PoseCorrection>& corrections, CorrectionReport* report);
  const KeyframeHistory& history() const { return history_; }
  // The history as loaded with a map (the map's objects and the views that made them).
  void setHistory(std::deque<KeyframeRecord> records);

  // Single-view processing of one object cloud in the depth camera frame: floor cut, filter, LCCP,
  // segment selection, box. Without a frame and detection the largest segment is kept. Used by
  // processKeyframe; public for tests and the single-frame baseline.
  bool processSingleView(const PointCloud& points_D, const Eigen::Isometry3d& T_W_D,
                         ObjectObservation* observation, StageTimes* times) const;
  Status processSingleView(const RgbdFrame& frame, const Detection2D& detection,
                           const PointCloud& points_D, ObjectObservation* observation,
                           StageTimes* times) const;
  const FloorEstimator& floor() const { return floor_; }
  // The floor's height along gravity().up, NaN when none was found yet.
  double floorHeight_m() const;
  // A loaded map's floor (NaN: nothing changes); later keyframes refine it as usual.
  void restoreFloor(double floor_height_m);

  const ObjectDatabase& database() const { return database_; }
  ObjectDatabase& mutableDatabase() { return database_; }
  // The configured gravity, else the estimate, else the default (0, 0, -1) until one exists.
  GravityFrame gravity() const;
  bool hasGravity() const;
  int keyframesProcessed() const { return keyframes_; }

  // A flag another thread may set to cancel the keyframe in progress (null: none). It is checked
  // between detections and between the stages of each (a stage itself, e.g. LCCP, runs to its
  // end); a cancelled processKeyframe() returns an error containing "cancelled" and leaves the map
  // as it was. The caller clears the flag; it must outlive the mapper or be reset to null.
  void setCancelFlag(const std::atomic<bool>* cancel) { cancel_ = cancel; }
  // Empties the database and the history and forgets the gravity estimate; ids keep counting
  // (never reused).
  void reset();

 private:
  // A keyframe's detections that pass Eq. 5 (ψ >= λ, a class we can name, a box that leaves
  // background), with their indices among the given detections.
  struct KeptDetections {
    std::vector<Detection2D> detections;
    std::vector<size_t> index;
  };
  // What a keyframe's detections share, computed once: the whole view (has_view: computed), the
  // depth in metres (evidence fusion; may be null) and each kept detection's cloud.
  struct KeyframeClouds {
    bool has_view = false;
    // The height of this keyframe's own floor layer (NaN: none seen), for the history.
    double floor_layer_m = std::numeric_limits<double>::quiet_NaN();
    SegmentSelector::FrameView view;
    std::shared_ptr<DepthView> depth_view;
    std::vector<PointCloud> clouds_D;
  };
  // One detection's single-view result; written by one job of the pool only.
  struct SingleView {
    Status status;
    ObjectObservation observation;
    StageTimes times;
    double wall_ms = 0.0;  // runSingleView's wall time
    int object_id = -1;    // the object it was fused into or inserted as
  };

  // processKeyframe's phases, in order.
  KeptDetections keepDetections(const RgbdFrame& frame, const std::vector<Detection2D>& detections,
                                const std::string& label, KeyframeReport* out) const;
  // Fills in the class id or name from the other; false if neither names a COCO class.
  static bool nameClass(Detection2D* detection);
  // False (and why) for a box over (nearly) the whole image when the consistent cut is used.
  bool boxLeavesBackground(const RgbdFrame& frame, const Detection2D& detection,
                           std::string* problem) const;
  // Eq. 1 and the shared inputs, on two jobs of the pool: the view and the floor from it; the
  // depth view and the detections' clouds.
  KeyframeClouds prepareKeyframe(const RgbdFrame& frame, const KeptDetections& kept,
                                 const std::string& label, KeyframeReport* out);
  // Adds the view's floor layer to the floor estimate; the layer's own height, NaN if none.
  double addFloorSample(const SegmentSelector::FrameView& view);
  std::shared_ptr<DepthView> makeDepthView(const cv::Mat& depth, const CameraIntrinsics& K_depth,
                                           const Eigen::Isometry3d& T_W_D) const;
  // One cloud per kept detection; a detection whose extraction fails gets an empty cloud and a
  // warning, the others their clouds.
  std::vector<PointCloud> extractClouds(const RgbdFrame& frame, const KeptDetections& kept,
                                        const std::string& label, KeyframeReport* out) const;
  // Sec. 3.2-3.3 for every kept detection, in parallel (largest clouds first).
  std::vector<SingleView> runSingleViews(const RgbdFrame& frame, const KeptDetections& kept,
                                         const KeyframeClouds& clouds) const;
  // Eq. 5-8 in detection order, then the deferred boxes of the objects that changed.
  // Completes out->drop_reasons (warnDetection set the first reason of each detection as it
  // warned): none for a mapped detection, the fault for an unmapped one of a fault keyframe.
  void noteDropReasons(KeyframeReport* out) const;
  void fuseKeyframe(const RgbdFrame& frame, int keyframe, const KeptDetections& kept,
                    const std::string& label, const std::shared_ptr<const DepthView>& depth_view,
                    std::vector<SingleView>* views, KeyframeReport* out);
  // One observation into the database (Eq. 6-8), its fused cloud processed by processFused; the
  // times of that added to *times.
  // object_id: the association decided for it (ObjectDatabase::associate), or kAssociateNow.
  ObjectDatabase::FusionResult fuseObservation(const ObjectObservation& observation,
                                               bool defer_rebox, StageTimes* times,
                                               int object_id = ObjectDatabase::kAssociateNow);
  // A keyframe's observations matched to the objects at once (ObjectDatabase::associate); its time
  // counts in the fusion.
  std::vector<int> associateKeyframe(const std::vector<const ObjectObservation*>& observations,
                                     StageTimes* times);
  // Evidence fusion, once per keyframe: the objects that changed boxed, in parallel.
  void reboxPending(StageTimes* times);
  // Existence evidence, once per keyframe after its fusion: every object votes with the keyframe's
  // depth (detected_ids: fused or inserted in it); the gone are removed (into *removed if given).
  void updateExistence(const DepthView* view, const std::vector<int>& detected_ids,
                       std::vector<MapObject>* removed);
  // What the keyframe's depth (view, may be null) says of the map's confirmed objects before its
  // fusion (nothing when the existence evidence is off): ExistenceModel::isFault tells a sensor
  // or SLAM fault, which neither votes nor is fused.
  ExistenceModel::DepthCheck checkKeyframeDepth(const DepthView* view) const;
  // A keyframe at pose T_W_D with this depth (may be null) that is a sensor or SLAM fault: its
  // pose upside down relative to gravity, or its depth contradicting most of the map
  // (checkKeyframeDepth); *why says so in the user's words.
  bool isKeyframeFault(const Eigen::Isometry3d& T_W_D, const DepthView* view,
                       std::string* why) const;
  // Not in the single-frame baseline (disable_fusion): its objects are single detections.
  bool existenceActive() const {
    return config_.database.existence.enable && config_.database.fusion == "evidence" &&
           !config_.database.disable_fusion;
  }
  // Sec. 3.5 on the database; the views of merged duplicates follow them into the history.
  RefinementReport refineDatabase();

  // The history (object_mapper_history.cpp): what the keyframe contributed, kept after its fusion;
  // the map rebuilt from it at the keyframes' current poses; a recorded view as the fusion takes it
  // again (its box re-estimated when the correction tilted it off gravity).
  // depth_fault: its views were not fused (isDepthFault), but are kept for a correction.
  void recordKeyframe(const RgbdFrame& frame, int keyframe, double floor_layer_m, bool depth_fault,
                      std::vector<SingleView>* views);
  // updateConfig with a new fusion grid: the map fused again from the history (every keyframe
  // counts as moved), or, without a history, nothing (the grid applies to the next fusions).
  void fuseAgainAtNewGrid(ReconfigureReport* report);
  // moved: the indices (into the history's records) of the keyframes the correction moved.
  void rebuildFromHistory(const std::vector<std::size_t>& moved, CorrectionReport* report);
  // What a record's replay needs that depends on that record alone: its depth view and its views
  // moved to the keyframe's current pose (built beside the replay of the record before it).
  struct ReplayInput {
    std::shared_ptr<const DepthView> depth_view;  // null where the replay needs none
    std::vector<ObjectObservation> observations;  // one per recorded view
  };
  ReplayInput prepareReplay(const KeyframeRecord& record) const;
  // What a rebuild made of the recorded views, in the rebuilt database's ids.
  struct ReplayOutcome {
    std::vector<int> rebuilt_ids;  // the rebuilt object of each recorded view, in history order
    std::set<int> gone_ids;        // rebuilt objects the existence evidence removed
    std::set<int> refined_ids;     // rebuilt objects the refinement removed
  };
  // One history record fused again from its prepared input.
  void replayRecord(const KeyframeRecord& record, ReplayInput* input, ReplayOutcome* outcome,
                    CorrectionReport* report);
  // The refinement of the rebuilt map, where it ran before.
  void refineRebuilt(ReplayOutcome* outcome);
  // A replayed view's box estimated again where the correction tilted it off gravity (grounded on
  // the floor as the replay has it so far), and its yaw.
  void alignReplayedBox(const KeyframeRecord& record, ObjectObservation* observation) const;
  // The ids of the rebuilt objects: each takes the id most of its views had before (the better
  // supported objects choose first), else a new one; objects of the old map that no view made are
  // kept as they were, and so are those whose removal no moved keyframe explains.
  // moved_record: per history record, whether the correction moved it.
  void adoptRebuiltIds(ObjectDatabase* previous, const ReplayOutcome& outcome,
                       const std::vector<bool>& moved_record, CorrectionReport* report);
  // Why each object of the previous map that the rebuilt map lacks went (final_id: the rebuilt
  // objects' ids); *restore: those no moved keyframe explains, to be kept as they were.
  void explainRemoved(const ObjectDatabase& previous, const ReplayOutcome& outcome,
                      const std::vector<bool>& moved_record, const std::map<int, int>& final_id,
                      std::set<int>* restore, CorrectionReport* report) const;

  bool processFused(const std::string& class_name, const PointCloud& points_W,
                    const std::vector<Eigen::Vector3f>& normals_W, PointCloud* segment_W,
                    OrientedBox* box, double* yaw_rad, StageTimes* times) const;
  // What the consistent segment selection needs to know about the view (all may be null).
  struct ViewContext {
    const RgbdFrame* frame = nullptr;
    const Detection2D* detection = nullptr;
    const SegmentSelector::FrameView* view = nullptr;
  };
  int threadCount() const;
  // processSingleView with the reason a detection was dropped.
  Status runSingleView(const PointCloud& points_D, const Eigen::Isometry3d& T_W_D,
                       const ViewContext& context, ObjectObservation* observation,
                       StageTimes* times) const;
  // runSingleView's phases: the floor cut and Sec. 3.2's filter; LCCP (Eq. 2); the segments that
  // are the object (masks: the detection's, when computed already); the box (Eq. 3/4) with the
  // cut's normals (null: none kept).
  Status filterView(const PointCloud& points_D, const Eigen::Isometry3d& T_W_D,
                    const GravityFrame& gravity_frame, PointCloud* filtered_D,
                    StageTimes* stage) const;
  // The points above the floor (and, with the filter, within its depth range); false if every
  // point lies on the floor.
  bool cutFloor(const PointCloud& points_D, const Eigen::Isometry3d& T_W_D,
                const GravityFrame& gravity_frame, PointCloud* above_floor_D) const;
  Status segmentView(const PointCloud& filtered_D, LccpSegmenter::Result* segmentation,
                     StageTimes* stage) const;
  Status selectCut(const PointCloud& filtered_D, const LccpSegmenter::Result& segmentation,
                   const ViewContext& context, const GravityFrame& gravity_frame,
                   const SegmentSelector::DetectionMasks* masks, PointCloud* cut_D,
                   StageTimes* stage) const;
  Status boxCut(const PointCloud& cut_D, const PointCloud& segment_W,
                const Eigen::Isometry3d& T_W_D, const std::string& class_name,
                const GravityFrame& gravity_frame, OrientedBox* box,
                std::vector<Eigen::Vector3f>* normals_W, StageTimes* stage) const;
  // Extends a box down to the floor when its bottom is near the floor, or wherever it is when its
  // class has a flat top on supports (ClassPrior::flat_top: a table whose legs are hidden).
  void groundBox(const std::string& class_name, OrientedBox* box) const;
  // Evidence fusion, flat_top classes (consistent selection): the points up to the top (the
  // highest 1 cm layer with selection.top_min_share of the points) + selection.top_clearance_m.
  // False (and *below_W unspecified) when that removes nothing or the class has no flat top.
  bool clipAboveFlatTop(const std::string& class_name, const PointCloud& points_W,
                        const GravityFrame& gravity, PointCloud* below_W) const;
  bool floorCutActive() const { return config_.floor.enable && floor_.hasFloor(); }
  // Updates the gravity estimate from the frame's depth when none is configured; false while
  // unknown.
  bool updateGravity(const RgbdFrame& frame);

  Config config_;
  ObjectCloudExtractor extractor_;
  PointCloudFilter filter_;
  LccpSegmenter lccp_;
  SegmentSelector selector_;
  FloorEstimator floor_;
  BoxEstimator box_estimator_;
  ObjectDatabase database_;
  PriorSizeFilter prior_filter_;
  IntersectionFilter intersection_filter_;
  GravityEstimator gravity_estimator_;
  KeyframeHistory history_;
  bool refined_ = false;  // refine() ran: a rebuilt map is refined again
  int keyframes_ = 0;
  const std::atomic<bool>* cancel_ = nullptr;
  bool cancelled() const { return cancel_ != nullptr && cancel_->load(std::memory_order_relaxed); }
};

}  // namespace mvod
