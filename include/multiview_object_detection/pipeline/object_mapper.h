// The whole per-keyframe pipeline (Sec. 3.1-3.5) behind one class: the offline runner, the ROS node
// and the tests all drive it.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

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
  bool waiting_for_gravity = false;  // detections skipped: no gravity estimate yet
  std::vector<std::string>
      warnings;  // per-detection problems (empty mask, no depth, unknown class ...)
  StageTimes times;
};

class ObjectMapper {
 public:
  // A detection's cloud with at least this many points has its selection masks (mask, core,
  // ring: a few milliseconds of erosion for ~100 000 pixels) computed on a thread of their own
  // beside its filter and LCCP, when num_threads allows more than one; the same masks either way.
  static constexpr size_t kMinPointsForMasksThread = 20000;

  struct Config {
    double min_probability = 0.5;  // λ
    // World gravity, pointing down. Zero vector = estimate it from the dominant horizontal plane.
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
    Status isValid() const;  // checks every sub-config
    std::string print() const;
    // The paper's method as published: Eq. 2's largest segment, Eq. 7's literal fusion, min/max
    // extents, no floor cut. The defaults are what measured best (README, Evaluation).
    void usePaperMethod();
  };

  struct RefinementReport {
    std::vector<int> atypical_ids;
    std::vector<int> intersecting_ids;
    // Of intersecting_ids: the duplicates merged into another object (merge_duplicates), as
    // (deleted id, id merged into).
    std::vector<std::pair<int, int>> merged_ids;
    double time_ms = 0.0;
  };

  ObjectMapper(const Config& config, const ClassPriors& priors);
  const Config& config() const { return config_; }
  // Replaces the configuration at run time (the ROS node's dynamic reconfigure, gravity from TF):
  // the stage objects are rebuilt, the database keeps its objects and ids, the gravity estimator
  // keeps its state (new gravity settings apply from the next reset()). An invalid config returns
  // the isValid() error and changes nothing.
  Status updateConfig(const Config& config);

  // Runs Sec. 3.1-3.4 on one keyframe and its detections. A bad frame returns an error and changes
  // nothing; problems with single detections are warnings in the report. Warnings name the frame.
  // Until gravity is known (configured or estimated) detections are skipped with a "waiting for
  // gravity" warning.
  Status processKeyframe(const RgbdFrame& frame, const std::vector<Detection2D>& detections,
                         KeyframeReport* report);
  // Sec. 3.5: removes atypical and intersecting objects from the database.
  RefinementReport refine();

  // Single-view processing of one object cloud in the depth camera frame: floor cut, filter, LCCP,
  // segment selection, box. Without a frame and detection the largest segment is kept. Used by
  // processKeyframe; public for tests and the single-frame baseline.
  bool processSingleView(const PointCloud& points_D, const Eigen::Isometry3d& T_W_D,
                         ObjectObservation* observation, StageTimes* times) const;
  Status processSingleView(const RgbdFrame& frame, const Detection2D& detection,
                           const PointCloud& points_D, ObjectObservation* observation,
                           StageTimes* times) const;
  const FloorEstimator& floor() const { return floor_; }

  const ObjectDatabase& database() const { return database_; }
  ObjectDatabase& mutableDatabase() { return database_; }
  // The configured gravity, else the estimate, else the default (0, 0, -1) until one exists.
  GravityFrame gravity() const;
  bool hasGravity() const;
  int keyframesProcessed() const { return keyframes_; }
  // Empties the database and forgets the gravity estimate; ids keep counting (never reused).
  void reset();

 private:
  bool processFused(const std::string& class_name, const PointCloud& points_W,
                    const std::vector<Eigen::Vector3f>& normals_W, PointCloud* segment_W,
                    OrientedBox* box, double* yaw_rad, StageTimes* times) const;
  // What the consistent segment selection needs to know about the view (all may be null).
  struct ViewContext {
    const RgbdFrame* frame = nullptr;
    const Detection2D* detection = nullptr;
    const SegmentSelector::FrameView* view = nullptr;
  };
  // processSingleView with the reason a detection was dropped.
  int threadCount() const;
  // job(0) ... job(count - 1) on up to `threads` threads (the caller's included); returns when all
  // are done.
  static void parallelFor(size_t count, int threads, const std::function<void(size_t)>& job);
  Status runSingleView(const PointCloud& points_D, const Eigen::Isometry3d& T_W_D,
                       const ViewContext& context, ObjectObservation* observation,
                       StageTimes* times) const;
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
  int keyframes_ = 0;
};

}  // namespace mvod
