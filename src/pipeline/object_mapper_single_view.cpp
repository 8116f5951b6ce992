// ObjectMapper's single-view stages (Sec. 3.2-3.4 on one detection): filter, floor cut, LCCP,
// segment selection and box, and the view's surface around the box for evidence fusion.
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "multiview_object_detection/pipeline/object_mapper.h"
#include "multiview_object_detection/pipeline/utils/parallel.h"
#include "multiview_object_detection/pipeline/utils/stopwatch.h"

namespace mvod {
namespace {

using Clock = StopwatchClock;

// The view's points from the depth rows that `box` grown by margin_m can project to: every point
// of the box projects inside the hull of its corners' projections when all of them lie in front of
// the camera; two rows more either side for the rounding of the stored points. All points when a
// corner lies behind the camera.
std::pair<size_t, size_t> viewRowsAround(const SegmentSelector::FrameView& view,
                                         const CameraIntrinsics& K, const Eigen::Isometry3d& T_W_D,
                                         const OrientedBox& box, double margin_m) {
  const std::pair<size_t, size_t> all(0, view.points_W.size());
  if (!K.isValid()) return all;
  const Eigen::Isometry3d T_D_W = T_W_D.inverse();
  const Eigen::Vector3d half = 0.5 * box.size_m + Eigen::Vector3d::Constant(margin_m + 1e-3);
  double v_min = std::numeric_limits<double>::infinity();
  double v_max = -v_min;
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3d corner_B((c & 1) ? half.x() : -half.x(), (c & 2) ? half.y() : -half.y(),
                                   (c & 4) ? half.z() : -half.z());
    const Eigen::Vector3d p_D = T_D_W * (box.center_m + box.rotation * corner_B);
    if (!(p_D.z() > 1e-3)) return all;
    const double v = K.fy * p_D.y() / p_D.z() + K.cy;
    v_min = std::min(v_min, v);
    v_max = std::max(v_max, v);
  }
  if (!(v_min > -1e6 && v_max < 1e6)) return all;
  return view.rows(static_cast<int>(std::floor(v_min)) - 2, static_cast<int>(std::ceil(v_max)) + 3);
}

// Evidence fusion: the view's surface points within 0.3 m of the box (in the box's frame), which
// vote on the voxels they see. frame: the view's, for its depth rows around the box (null: all).
void addSeenAroundBox(const SegmentSelector::FrameView& view, const RgbdFrame* frame,
                      const Eigen::Isometry3d& T_W_D, const OrientedBox& box, PointCloud* seen_W) {
  const Eigen::Matrix3f R_B_W = box.rotation.transpose().cast<float>();
  const Eigen::Vector3f centre = box.center_m.cast<float>();
  const Eigen::Vector3f half = (0.5 * box.size_m).cast<float>() + Eigen::Vector3f::Constant(0.3f);
  const std::pair<size_t, size_t> range =
      frame != nullptr ? viewRowsAround(view, frame->K_depth, T_W_D, box, 0.3)
                       : std::make_pair(size_t{0}, view.points_W.size());
  for (size_t k = range.first; k < range.second; ++k) {
    const Eigen::Vector3f& p_W = view.points_W[k];
    if (((R_B_W * (p_W - centre)).cwiseAbs() - half).maxCoeff() <= 0.f) seen_W->push_back(p_W);
  }
}

}  // namespace

bool ObjectMapper::processSingleView(const PointCloud& points_D, const Eigen::Isometry3d& T_W_D,
                                     ObjectObservation* observation, StageTimes* times) const {
  return runSingleView(points_D, T_W_D, ViewContext(), observation, times).ok();
}

Status ObjectMapper::processSingleView(const RgbdFrame& frame, const Detection2D& detection,
                                       const PointCloud& points_D, ObjectObservation* observation,
                                       StageTimes* times) const {
  const SegmentSelector::FrameView view = SegmentSelector::makeFrameView(
      frame, 2, config_.extractor.min_valid_depth_m, config_.extractor.max_valid_depth_m);
  ViewContext context;
  context.frame = &frame;
  context.detection = &detection;
  context.view = &view;
  return runSingleView(points_D, frame.T_W_D, context, observation, times);
}

void ObjectMapper::groundBox(const std::string& class_name, OrientedBox* box) const {
  if (!floorCutActive()) return;
  const ClassPrior* prior = database_.priors().find(class_name);
  // A flat top stands on supports down to the floor, whatever of them a view shows.
  const bool to_floor = prior != nullptr && prior->flat_top;
  const Eigen::Vector3d up = box->rotation.col(2);
  if (up.dot(gravity().up) < 0.999) return;  // not gravity-aligned
  const double centre = up.dot(box->center_m);
  const double bottom = centre - 0.5 * box->size_m.z();
  const double top = centre + 0.5 * box->size_m.z();
  const double floor_m = floor_.floorHeight_m();
  // Near the floor, or (a flat-topped class) anywhere above it: a table's legs hidden behind
  // chairs still reach the floor. (Not every on_floor class: grounding the fragments of a chair
  // would give them a chair's height and centre, and Eq. 6 would fuse them into their neighbours.)
  if (top <= floor_m + 0.05) return;
  if (!to_floor && bottom - floor_m > config_.floor.grounding_distance_m) return;
  box->size_m.z() = top - floor_m;
  box->center_m += up * (0.5 * (top + floor_m) - centre);
}

bool ObjectMapper::clipAboveFlatTop(const std::string& class_name, const PointCloud& points_W,
                                    const GravityFrame& gravity, PointCloud* below_W) const {
  const ClassPrior* prior = database_.priors().find(class_name);
  if (prior == nullptr || !prior->flat_top || !config_.selection.consistent()) return false;
  return SegmentSelector::belowFlatTop(points_W, gravity.up, config_.selection.top_clearance_m,
                                       config_.selection.top_min_share, below_W);
}

Status ObjectMapper::runSingleView(const PointCloud& points_D, const Eigen::Isometry3d& T_W_D,
                                   const ViewContext& context, ObjectObservation* observation,
                                   StageTimes* times) const {
  StageTimes local_times;
  StageTimes& stage = times != nullptr ? *times : local_times;
  const GravityFrame gravity_frame = gravity();

  // The selection's image work (the detection's mask, core and ring) does not depend on the
  // cloud: for a large detection, when the mapper has more than one thread, it runs as a job of
  // its own beside the filter and LCCP (the same masks select() would compute).
  SegmentSelector::DetectionMasks masks;
  const bool masks_beside = config_.selection.consistent() && context.detection != nullptr &&
                            context.frame != nullptr && threadCount() > 1 &&
                            points_D.size() >= kMinPointsForMasksThread;
  PointCloud filtered_D;
  LccpSegmenter::Result segmentation;
  Status segmented;
  const auto filter_and_segment = [&] {
    segmented = filterView(points_D, T_W_D, gravity_frame, &filtered_D, &stage);
    if (segmented) segmented = segmentView(filtered_D, &segmentation, &stage);
  };
  if (masks_beside) {
    parallelInvoke(
        threadCount(),
        [this, &masks, &context] {
          masks = selector_.detectionMasks(*context.detection, context.frame->color_bgr.size());
        },
        filter_and_segment);
  } else {
    filter_and_segment();
  }
  if (!segmented) return segmented;
  if (cancelled()) return Status::Error("cancelled");

  PointCloud cut_D;
  const Status selected = selectCut(filtered_D, segmentation, context, gravity_frame,
                                    masks_beside ? &masks : nullptr, &cut_D, &stage);
  if (!selected) return selected;
  if (cancelled()) return Status::Error("cancelled");

  // Eq. 1: into the world frame, then Eq. 3/4 on the segment.
  PointCloud points_W = transformCloud(filtered_D, T_W_D);
  PointCloud segment_W = transformCloud(cut_D, T_W_D);
  OrientedBox box;
  const bool evidence = config_.database.fusion == "evidence";
  std::vector<Eigen::Vector3f> normals_W;
  const Status boxed =
      boxCut(cut_D, segment_W, T_W_D,
             context.detection != nullptr ? context.detection->class_name : std::string(),
             gravity_frame, &box, evidence ? &normals_W : nullptr, &stage);
  if (!boxed) return boxed;

  if (evidence) {
    // Evidence fusion: the view's surface around the box votes on the voxels it sees.
    if (context.view != nullptr) {
      addSeenAroundBox(*context.view, context.frame, T_W_D, box, &observation->seen_W);
    }
    // The voxels this view votes on, here on the pool rather than in the ordered fusion.
    observation->fusion_keys = std::make_shared<const FusionKeys>(
        makeFusionKeys(segment_W, observation->seen_W, config_.database.fusion_voxel_size_m));
  }
  observation->points_W = std::move(points_W);
  observation->segment_W = std::move(segment_W);
  observation->segment_normals_W = std::move(normals_W);
  observation->box = box;
  observation->yaw_rad = gravity_frame.yawOf(box.rotation.col(0));
  return Status::Ok();
}

Status ObjectMapper::filterView(const PointCloud& points_D, const Eigen::Isometry3d& T_W_D,
                                const GravityFrame& gravity_frame, PointCloud* filtered_D,
                                StageTimes* stage) const {
  // Sec. 3.2: pass-through, voxel grid and outlier removal in the camera frame; before them the
  // floor cut: points just above the floor are floor, whatever the mask says.
  const Clock::time_point t = Clock::now();
  PointCloud above_floor_D;
  const PointCloud* input_D = &points_D;
  if (floorCutActive()) {
    if (!cutFloor(points_D, T_W_D, gravity_frame, &above_floor_D)) {
      stage->filter_ms += msSince(t);
      return Status::Error("every point lies on the floor (" + std::to_string(points_D.size()) +
                           " points)");
    }
    input_D = &above_floor_D;
  }
  *filtered_D = !config_.filter.enable ? *input_D
                : floorCutActive()     ? filter_.filterPassedThrough(*input_D)
                                       : filter_.filterCameraFrame(*input_D);
  stage->filter_ms += msSince(t);
  if (static_cast<int>(filtered_D->size()) < config_.min_object_points) {
    return Status::Error("only " + std::to_string(filtered_D->size()) + " of " +
                         std::to_string(points_D.size()) +
                         " points left after filtering (min_object_points " +
                         std::to_string(config_.min_object_points) + ")");
  }
  return Status::Ok();
}

bool ObjectMapper::cutFloor(const PointCloud& points_D, const Eigen::Isometry3d& T_W_D,
                            const GravityFrame& gravity_frame, PointCloud* above_floor_D) const {
  const Eigen::Vector3f up_D = (T_W_D.linear().transpose() * gravity_frame.up).cast<float>();
  const float up_offset = static_cast<float>(gravity_frame.up.dot(T_W_D.translation()));
  const float floor_m = static_cast<float>(floor_.floorHeight_m());
  const float clearance_m = static_cast<float>(config_.floor.clearance_m);
  const float per_m2 = static_cast<float>(config_.floor.clearance_per_m2);
  // With the filter, its pass-through in the same pass: one copy of the cloud, not two.
  const bool pass_through = config_.filter.enable;
  const double min_depth_m = config_.filter.min_depth_m;
  const double max_depth_m = config_.filter.max_depth_m;
  above_floor_D->reserve(points_D.size());
  size_t above = 0;
  for (const Eigen::Vector3f& p : points_D) {
    const float height_m = up_D.dot(p) + up_offset - floor_m;
    if (!(height_m >= clearance_m + per_m2 * p.z() * p.z())) continue;
    ++above;
    if (!pass_through || PointCloudFilter::inDepthRange(p, min_depth_m, max_depth_m)) {
      above_floor_D->push_back(p);
    }
  }
  return above > 0;
}

Status ObjectMapper::segmentView(const PointCloud& filtered_D, LccpSegmenter::Result* segmentation,
                                 StageTimes* stage) const {
  // Eq. 2 in the camera frame, where LCCP's log-depth transform applies.
  const Clock::time_point t = Clock::now();
  const Status segmented = lccp_.segment(filtered_D, true, segmentation);
  stage->lccp_ms += msSince(t);
  if (!segmented) return Status::Error("LCCP failed: " + segmented.message());
  if (segmentation->largest_segment.empty()) return Status::Error("LCCP left no segment");
  return Status::Ok();
}

Status ObjectMapper::selectCut(const PointCloud& filtered_D,
                               const LccpSegmenter::Result& segmentation,
                               const ViewContext& context, const GravityFrame& gravity_frame,
                               const SegmentSelector::DetectionMasks* masks, PointCloud* cut_D,
                               StageTimes* stage) const {
  // Eq. 2, or the segments consistent with the detection.
  const Clock::time_point t = Clock::now();
  SegmentSelector::Input selection_input;
  selection_input.points_D = &filtered_D;
  selection_input.segments = &segmentation.segments;
  selection_input.detection = context.detection;
  selection_input.frame = context.frame;
  selection_input.view = context.view;
  selection_input.prior = context.detection != nullptr
                              ? database_.priors().find(context.detection->class_name)
                              : nullptr;
  selection_input.gravity = gravity_frame;
  selection_input.masks = masks;
  SegmentSelector::Result selection;
  const Status selected = selector_.select(selection_input, &selection);
  stage->lccp_ms += msSince(t);
  if (!selected) return Status::Error("no object in the cut: " + selected.message());
  cut_D->reserve(selection.indices.size());
  for (const int i : selection.indices) cut_D->push_back(filtered_D[i]);
  if (static_cast<int>(cut_D->size()) < config_.box.min_points) {
    return Status::Error("the cut holds only " + std::to_string(cut_D->size()) + " points");
  }
  return Status::Ok();
}

Status ObjectMapper::boxCut(const PointCloud& cut_D, const PointCloud& segment_W,
                            const Eigen::Isometry3d& T_W_D, const std::string& class_name,
                            const GravityFrame& gravity_frame, OrientedBox* box,
                            std::vector<Eigen::Vector3f>* normals_W, StageTimes* stage) const {
  const Clock::time_point t = Clock::now();
  // The cut's median depth sets the normal radius (the sensor's depth layers).
  std::vector<float> depths_m;
  depths_m.reserve(cut_D.size());
  for (const Eigen::Vector3f& p : cut_D) depths_m.push_back(p.z());
  std::nth_element(depths_m.begin(), depths_m.begin() + depths_m.size() / 2, depths_m.end());
  const double median_depth_m = depths_m[depths_m.size() / 2];
  const Status boxed =
      box_estimator_.estimate(segment_W, gravity_frame, box, nullptr, normals_W, median_depth_m);
  if (boxed) groundBox(class_name, box);
  if (normals_W != nullptr) {
    // Turned towards the camera: every view of a surface then adds the same sign in a voxel.
    const Eigen::Vector3f camera_W = T_W_D.translation().cast<float>();
    for (size_t i = 0; i < normals_W->size(); ++i) {
      Eigen::Vector3f& n = (*normals_W)[i];
      if (n.allFinite() && n.dot(camera_W - segment_W[i]) < 0.f) n = -n;
    }
  }
  stage->manhattan_ms += msSince(t);
  if (!boxed) return Status::Error("no box: " + boxed.message());
  return Status::Ok();
}

}  // namespace mvod
