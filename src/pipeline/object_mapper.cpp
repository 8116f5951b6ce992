#include "multiview_object_detection/pipeline/object_mapper.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>
#include <utility>

#include "multiview_object_detection/pipeline/utils/parallel.h"

namespace mvod {
namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// Prefixes every line of a sub-config's print() with its section name.
void appendSection(const std::string& section, const std::string& lines, std::ostringstream* out) {
  std::istringstream in(lines);
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty()) *out << section << "." << line << "\n";
  }
}

Status checkSection(const std::string& section, const Status& status) {
  if (status.ok()) return status;
  // checkParameterRange's messages name the parameter as the YAML file does already.
  if (status.message().rfind(section + "/", 0) == 0) return status;
  return Status::Error(section + "." + status.message());
}

std::string frameLabel(const RgbdFrame& frame) {
  return frame.name.empty() ? "frame " + std::to_string(frame.index) : frame.name;
}

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

std::string detectionLabel(size_t index, const Detection2D& detection) {
  std::ostringstream out;
  out << "detection " << index << " ('" << detection.class_name << "' " << detection.score << ")";
  return out.str();
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

// The single-view stages' times (filter, LCCP, box) of `from` added to *to: summed over
// detections (CPU time where they ran in parallel).
void addStageTimes(const StageTimes& from, StageTimes* to) {
  to->filter_ms += from.filter_ms;
  to->lccp_ms += from.lccp_ms;
  to->manhattan_ms += from.manhattan_ms;
}

}  // namespace

Status ObjectMapper::Config::isValid() const {
  if (!(std::isfinite(min_probability) && min_probability >= 0.0 && min_probability <= 1.0)) {
    return Status::Error("min_probability must be in [0, 1] (got " +
                         std::to_string(min_probability) + ")");
  }
  if (!gravity_down_W.allFinite()) {
    return Status::Error("gravity_down_W must be finite (zero = estimate it)");
  }
  if (num_threads < 0 || num_threads > 256) {
    return Status::Error("num_threads must be in [0, 256] (got " + std::to_string(num_threads) +
                         ")");
  }
  if (min_object_points < 1) {
    return Status::Error("min_object_points must be >= 1 (got " +
                         std::to_string(min_object_points) + ")");
  }
  Status status;
  if (!(status = checkSection("extractor", extractor.isValid()))) return status;
  if (!(status = checkSection("filter", filter.isValid()))) return status;
  if (!(status = checkSection("lccp", lccp.isValid()))) return status;
  if (!(status = checkSection("selection", selection.isValid()))) return status;
  if (!(status = checkSection("floor", floor.isValid()))) return status;
  if (!(status = checkSection("box", box.isValid()))) return status;
  if (!(status = checkSection("database", database.isValid()))) return status;
  if (!(status = checkSection("prior_filter", prior_filter.isValid()))) return status;
  if (!(status = checkSection("intersection_filter", intersection_filter.isValid()))) return status;
  if (!(status = checkSection("gravity", gravity.isValid()))) return status;
  if (!(status = checkSection("corrections", corrections.isValid()))) return status;
  return Status::Ok();
}

std::string ObjectMapper::Config::print() const {
  std::ostringstream out;
  out << "min_probability: " << min_probability << "\n"
      << "gravity_down_W: [" << gravity_down_W.x() << ", " << gravity_down_W.y() << ", "
      << gravity_down_W.z() << "]" << (gravity_down_W.isZero() ? " (estimated)" : "") << "\n"
      << "min_object_points: " << min_object_points << "\n"
      << "num_threads: " << num_threads << "\n";
  appendSection("extractor", extractor.print(), &out);
  appendSection("filter", filter.print(), &out);
  appendSection("lccp", lccp.print(), &out);
  appendSection("selection", selection.print(), &out);
  appendSection("floor", floor.print(), &out);
  appendSection("box", box.print(), &out);
  appendSection("database", database.print(), &out);
  appendSection("prior_filter", prior_filter.print(), &out);
  appendSection("intersection_filter", intersection_filter.print(), &out);
  appendSection("gravity", gravity.print(), &out);
  appendSection("corrections", corrections.print(), &out);
  return out.str();
}

void ObjectMapper::Config::usePaperMethod() {
  selection.selection = "largest";
  database.fusion = "paper";
  floor.enable = false;
  box.extent_trim_fraction = 0.0;
  box.depth_step_per_m2 = 0.0;
  box.footprint_yaw_area_ratio = 0.0;
  box.outline_cell_m = 0.0;
  box.normal_estimation = "radius";
  extractor.min_consistent_neighbours = 0;
  extractor.near_sampling_leaf_m = 0.0;
  filter.outlier_removal = "statistical";
  lccp.implementation = "pcl";
  intersection_filter.duplicate_ratio = 0.0;
  intersection_filter.container_support_ratio = 0.0;
  database.amodal.enable = false;
  database.existence.enable = false;
  corrections.enable = false;
}

namespace {

// Table 3's -Filter switches the depth-edge test of the extraction off with the filters, and the
// near sampling with the voxel grid that averages it.
ObjectCloudExtractor::Config extractorConfig(const ObjectMapper::Config& config) {
  ObjectCloudExtractor::Config extractor = config.extractor;
  if (!config.filter.enable) {
    extractor.min_consistent_neighbours = 0;
    extractor.near_sampling_leaf_m = 0.0;
  }
  return extractor;
}

int poolSize(const ObjectMapper::Config& config) {
  return config.num_threads > 0
             ? config.num_threads
             : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

// One cloud's outlier removal and normals may use the mapper's threads too (the pool's size): a
// large detection then does not leave a core idle once the keyframe's other detections are done.
PointCloudFilter::Config filterConfig(const ObjectMapper::Config& config) {
  PointCloudFilter::Config filter = config.filter;
  filter.num_threads = poolSize(config);
  return filter;
}

LccpSegmenter::Config lccpConfig(const ObjectMapper::Config& config) {
  LccpSegmenter::Config lccp = config.lccp;
  lccp.num_threads = poolSize(config);
  return lccp;
}

BoxEstimator::Config boxConfig(const ObjectMapper::Config& config) {
  BoxEstimator::Config box = config.box;
  box.num_threads = poolSize(config);
  return box;
}

}  // namespace

ObjectMapper::ObjectMapper(const Config& config, const ClassPriors& priors)
    : config_(config),
      extractor_(extractorConfig(config)),
      filter_(filterConfig(config)),
      lccp_(lccpConfig(config)),
      selector_(config.selection),
      floor_(config.floor),
      box_estimator_(boxConfig(config)),
      database_(config.database, priors),
      prior_filter_(config.prior_filter),
      intersection_filter_(config.intersection_filter),
      gravity_estimator_(config.gravity),
      history_(config.corrections) {}

Status ObjectMapper::updateConfig(const Config& config) {
  const Status valid = config.isValid();
  if (!valid) return valid;
  config_ = config;
  extractor_ = ObjectCloudExtractor(extractorConfig(config));
  filter_ = PointCloudFilter(filterConfig(config));
  lccp_ = LccpSegmenter(lccpConfig(config));
  selector_ = SegmentSelector(config.selection);
  const FloorEstimator previous_floor = floor_;
  floor_ = FloorEstimator(config.floor);
  if (previous_floor.hasFloor()) floor_.setFloor(previous_floor.floorHeight_m(), gravity().up);
  box_estimator_ = BoxEstimator(boxConfig(config));
  database_.setConfig(config.database);
  prior_filter_ = PriorSizeFilter(config.prior_filter);
  intersection_filter_ = IntersectionFilter(config.intersection_filter);
  history_.setConfig(config.corrections);
  return Status::Ok();
}

GravityFrame ObjectMapper::gravity() const {
  if (!config_.gravity_down_W.isZero()) return GravityFrame(config_.gravity_down_W);
  if (gravity_estimator_.hasEstimate()) return GravityFrame(gravity_estimator_.gravityDown_W());
  return GravityFrame();
}

bool ObjectMapper::hasGravity() const {
  return !config_.gravity_down_W.isZero() || gravity_estimator_.hasEstimate();
}

bool ObjectMapper::updateGravity(const RgbdFrame& frame) {
  if (hasGravity()) return true;
  // Every 4th pixel is plenty for a dominant plane and keeps this cheap.
  const PointCloud points_D = ObjectCloudExtractor::backProjectDepth(
      frame.depth, frame.K_depth, 4, config_.extractor.min_valid_depth_m,
      config_.extractor.max_valid_depth_m);
  return gravity_estimator_.addFrame(points_D, frame.T_W_D);
}

double ObjectMapper::floorHeight_m() const {
  return floor_.hasFloor() ? floor_.floorHeight_m() : std::numeric_limits<double>::quiet_NaN();
}

void ObjectMapper::restoreFloor(double floor_height_m) {
  if (std::isfinite(floor_height_m)) floor_.setFloor(floor_height_m, gravity().up);
}

void ObjectMapper::reset() {
  database_.clear();
  history_.clear();
  refined_ = false;
  gravity_estimator_ = GravityEstimator(config_.gravity);
  floor_.reset();
  keyframes_ = 0;
}

Status ObjectMapper::processKeyframe(const RgbdFrame& frame,
                                     const std::vector<Detection2D>& detections,
                                     KeyframeReport* report) {
  const Clock::time_point start = Clock::now();
  KeyframeReport local_report;
  KeyframeReport& out = report != nullptr ? *report : local_report;
  out = KeyframeReport();
  out.detections = static_cast<int>(detections.size());

  // A bad frame changes nothing.
  const Status valid = frame.validate();
  if (!valid) return valid;

  const std::string label = frameLabel(frame);
  const int keyframe = keyframes_++;

  if (!updateGravity(frame)) {
    out.waiting_for_gravity = true;
    out.warnings.push_back(label +
                           ": waiting for gravity (no dominant horizontal plane seen yet); " +
                           std::to_string(detections.size()) + " detection(s) skipped");
    out.times.total_ms = msSince(start);
    return Status::Ok();
  }

  const KeptDetections kept = keepDetections(frame, detections, label, &out);
  // Eq. 1: one cloud per detection, back-projected once for the whole frame.
  Clock::time_point t = Clock::now();
  const KeyframeClouds clouds = prepareKeyframe(frame, kept, label, &out.warnings);
  out.times.extraction_ms = msSince(t);
  std::vector<SingleView> views = runSingleViews(frame, kept, clouds);
  if (cancelled()) {
    --keyframes_;  // nothing of it is in the map
    return Status::Error(label + ": cancelled");
  }
  fuseKeyframe(frame, keyframe, kept, label, clouds.depth_view, &views, &out);
  recordKeyframe(frame, keyframe, clouds.floor_layer_m, &views);
  out.times.total_ms = msSince(start);
  return Status::Ok();
}

ObjectMapper::KeptDetections ObjectMapper::keepDetections(
    const RgbdFrame& frame, const std::vector<Detection2D>& detections, const std::string& label,
    KeyframeReport* out) const {
  // Eq. 5: only detections with ψ >= λ, of a class we can name.
  KeptDetections kept;
  for (size_t i = 0; i < detections.size(); ++i) {
    const Detection2D& detection = detections[i];
    if (!(detection.score >= 0.f && detection.score <= 1.f)) {
      // A probability is what the map stores and averages (Eq. 8); a percentage would make a map
      // that cannot be reloaded.
      out->warnings.push_back(label + ": " + detectionLabel(i, detection) +
                              ": score is not a probability in [0, 1], skipped");
      continue;
    }
    if (!(detection.score >= config_.min_probability)) continue;
    ++out->above_threshold;
    Detection2D named = detection;
    if (!nameClass(&named)) {
      out->warnings.push_back(label + ": " + detectionLabel(i, detection) +
                              ": unknown class (not a COCO class name), skipped");
      continue;
    }
    std::string problem;
    if (!boxLeavesBackground(frame, named, &problem)) {
      out->warnings.push_back(label + ": " + detectionLabel(i, detection) + ": " + problem);
      continue;
    }
    kept.detections.push_back(std::move(named));
    kept.index.push_back(i);
  }
  return kept;
}

bool ObjectMapper::nameClass(Detection2D* detection) {
  const std::vector<std::string>& coco = cocoClassNames();
  if (detection->class_id < 0 || detection->class_id >= static_cast<int>(coco.size())) {
    detection->class_id = cocoClassId(detection->class_name);
  }
  if (detection->class_name.empty() && detection->class_id >= 0) {
    detection->class_name = coco[detection->class_id];
  }
  return detection->class_id >= 0 && !detection->class_name.empty();
}

bool ObjectMapper::boxLeavesBackground(const RgbdFrame& frame, const Detection2D& detection,
                                       std::string* problem) const {
  // The consistent cut refuses a box over (nearly) the whole image; it is refused here already,
  // before its cloud (the whole view) is extracted.
  const cv::Rect image_rect(cv::Point(0, 0), frame.color_bgr.size());
  const cv::Rect box = detection.box_px & image_rect;
  if (config_.selection.consistent() &&
      box.area() > config_.selection.max_box_image_fraction * image_rect.area()) {
    *problem = "no object in the cut: the box covers the whole image (" +
               std::to_string(100 * box.area() / std::max(1, image_rect.area())) +
               " %): no background to cut the object from";
    return false;
  }
  return true;
}

ObjectMapper::KeyframeClouds ObjectMapper::prepareKeyframe(const RgbdFrame& frame,
                                                           const KeptDetections& kept,
                                                           const std::string& label,
                                                           std::vector<std::string>* warnings) {
  // The whole view, once: the floor's height, and the surfaces around each detection for the
  // consistent selection and the evidence fusion.
  KeyframeClouds clouds;
  clouds.has_view = config_.floor.enable || config_.selection.consistent() ||
                    config_.database.fusion == "evidence";
  // Two independent jobs on the pool: the view (and the floor from it), and the keyframe's depth
  // in metres plus the detections' clouds. Each writes only its own results.
  const auto view_and_floor = [&]() {
    if (clouds.has_view) {
      clouds.view = SegmentSelector::makeFrameView(frame, 2, config_.extractor.min_valid_depth_m,
                                                   config_.extractor.max_valid_depth_m);
    }
    if (config_.floor.enable) clouds.floor_layer_m = addFloorSample(clouds.view);
  };
  const auto depth_and_clouds = [&]() {
    // Evidence fusion's surface test: the keyframe's depth in metres, shared by its detections.
    // Also amodal completion's free space.
    // The existence evidence tests every object against every keyframe's depth.
    if (config_.database.fusion == "evidence" &&
        (((config_.database.surface_band_m > 0.0 || config_.database.amodal.enable) &&
          !kept.detections.empty()) ||
         existenceActive())) {
      clouds.depth_view = makeDepthView(frame.depth, frame.K_depth, frame.T_W_D);
    }
    clouds.clouds_D = extractClouds(frame, kept, label, warnings);
  };
  parallelInvoke(threadCount(), view_and_floor, depth_and_clouds);
  return clouds;
}

double ObjectMapper::addFloorSample(const SegmentSelector::FrameView& view) {
  // Every 2nd point of the view is plenty for the floor's layer.
  PointCloud sample_W;
  sample_W.reserve(view.points_W.size() / 2 + 1);
  for (size_t i = 0; i < view.points_W.size(); i += 2) sample_W.push_back(view.points_W[i]);
  double layer_m = std::numeric_limits<double>::quiet_NaN();
  floor_.addFrame(sample_W, gravity(), &layer_m);
  return layer_m;
}

std::shared_ptr<DepthView> ObjectMapper::makeDepthView(const cv::Mat& depth,
                                                       const CameraIntrinsics& K_depth,
                                                       const Eigen::Isometry3d& T_W_D) const {
  // 0 where invalid (NaN, or outside the extractor's valid range: 0 and 65535 mm too). The band,
  // plus three depth steps: what lies further behind the measured surface is hidden.
  return mvod::makeDepthView(depth, K_depth, T_W_D, config_.extractor.min_valid_depth_m,
                             config_.extractor.max_valid_depth_m, config_.database.surface_band_m,
                             3.0 * config_.extractor.depth_step_per_m2);
}

std::vector<PointCloud> ObjectMapper::extractClouds(const RgbdFrame& frame,
                                                    const KeptDetections& kept,
                                                    const std::string& label,
                                                    std::vector<std::string>* warnings) const {
  const std::vector<Detection2D>& detections = kept.detections;
  std::vector<PointCloud> clouds_D;
  const Status extracted = extractor_.extract(frame, detections, &clouds_D);
  if (extracted && clouds_D.size() == detections.size()) return clouds_D;
  // One bad detection (a mask of the wrong size, say) must not cost the others: retry one by one.
  clouds_D.assign(detections.size(), PointCloud());
  for (size_t k = 0; k < detections.size(); ++k) {
    std::vector<PointCloud> single;
    const Status status = extractor_.extract(frame, {detections[k]}, &single);
    if (!status || single.size() != 1) {
      warnings->push_back(label + ": " + detectionLabel(kept.index[k], detections[k]) + ": " +
                          (status ? std::string("extraction failed") : status.message()));
      continue;
    }
    clouds_D[k] = std::move(single[0]);
  }
  return clouds_D;
}

std::vector<ObjectMapper::SingleView> ObjectMapper::runSingleViews(
    const RgbdFrame& frame, const KeptDetections& kept, const KeyframeClouds& clouds) const {
  // Sec. 3.2-3.3 for each detection, on the thread pool: each reads the frame and the mapper's
  // settings only, and writes its own slot.
  const std::vector<PointCloud>& clouds_D = clouds.clouds_D;
  std::vector<SingleView> views(kept.detections.size());
  const auto run_one = [&](size_t k) {
    if (cancelled()) {
      views[k].status = Status::Error("cancelled");
      return;
    }
    if (clouds_D[k].empty()) {
      views[k].status = Status::Error("no valid depth inside the mask");
      return;
    }
    ViewContext context;
    context.frame = &frame;
    context.detection = &kept.detections[k];
    context.view = clouds.has_view ? &clouds.view : nullptr;
    views[k].status =
        runSingleView(clouds_D[k], frame.T_W_D, context, &views[k].observation, &views[k].times);
  };
  // Largest clouds first: the pool then ends with small jobs instead of waiting on one big one.
  std::vector<size_t> by_size(views.size());
  for (size_t k = 0; k < by_size.size(); ++k) by_size[k] = k;
  std::stable_sort(by_size.begin(), by_size.end(), [&clouds_D](size_t a, size_t b) {
    return clouds_D[a].size() > clouds_D[b].size();
  });
  parallelForEach(views.size(), threadCount(), [&](size_t j) { run_one(by_size[j]); });
  return views;
}

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
  for (size_t k = 0; k < kept.detections.size(); ++k) {
    const Detection2D& detection = kept.detections[k];
    SingleView& view = (*views)[k];
    // Stage times are summed over detections (CPU time when they ran in parallel).
    addStageTimes(view.times, &out->times);
    if (!view.status) {
      out->warnings.push_back(label + ": " + detectionLabel(kept.index[k], detection) + ": " +
                              view.status.message());
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
    const ObjectDatabase::FusionResult result =
        fuseObservation(observation, defer_rebox, &out->times);
    view.object_id = result.object_id;
    if (result.decision == ObjectDatabase::Decision::kFused) {
      ++out->fused;
    } else {
      ++out->inserted;
    }
  }
  if (!database_.pendingRebox().empty()) reboxPending(&out->times);
  if (existenceActive()) {
    std::vector<int> detected_ids;
    for (const SingleView& view : *views) {
      if (view.status && view.object_id >= 0) detected_ids.push_back(view.object_id);
    }
    const Clock::time_point t = Clock::now();
    updateExistence(depth_view.get(), detected_ids, &out->removed);
    out->times.existence_ms += msSince(t);
  }
}

void ObjectMapper::updateExistence(const DepthView* view, const std::vector<int>& detected_ids,
                                   std::vector<MapObject>* removed) {
  for (const int id : database_.updateExistence(view, detected_ids)) {
    if (removed != nullptr && database_.find(id) != nullptr)
      removed->push_back(*database_.find(id));
    database_.remove(id);
  }
}

ObjectDatabase::FusionResult ObjectMapper::fuseObservation(const ObjectObservation& observation,
                                                           bool defer_rebox, StageTimes* times) {
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
      database_.fuseOrInsert(observation, process, defer_rebox);
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

int ObjectMapper::threadCount() const { return poolSize(config_); }

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
    report.atypical_ids = prior_filter_.atypicalObjects(database_);
    for (const int id : report.atypical_ids) database_.remove(id);
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
        if (database_.mergeInto(duplicate.second, duplicate.first, process)) {
          report.merged_ids.push_back(duplicate);
        }
      }
    }
    for (const int id : report.intersecting_ids) database_.remove(id);
  }
  report.time_ms = msSince(start);
  return report;
}

}  // namespace mvod
