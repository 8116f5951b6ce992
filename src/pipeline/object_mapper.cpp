// ObjectMapper (the paper's pipeline per keyframe): its configuration, gravity and floor, and a
// keyframe's path: detections kept, clouds extracted, single views run in parallel. The single-view
// stages are in object_mapper_single_view.cpp, fusion and refinement in object_mapper_fusion.cpp,
// the keyframe history and SLAM corrections in object_mapper_history.cpp.
#include "multiview_object_detection/pipeline/object_mapper.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <thread>
#include <utility>

#include "multiview_object_detection/pipeline/utils/parallel.h"
#include "multiview_object_detection/pipeline/utils/stopwatch.h"
#include "object_mapper_detail.h"

namespace mvod {
namespace {

using object_mapper_detail::addStageTimes;
using object_mapper_detail::warnDetection;

using Clock = StopwatchClock;

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
  extractor.max_depth_edge_margin_px = 0;
  extractor.near_sampling_leaf_m = 0.0;
  filter.outlier_removal = "statistical";
  lccp.implementation = "pcl";
  intersection_filter.duplicate_ratio = 0.0;
  intersection_filter.container_support_ratio = 0.0;
  intersection_filter.flat_top_clearance_m = 0.0;
  database.amodal.enable = false;
  database.existence.enable = false;
  database.view_consensus_m = 0.0;
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

Status ObjectMapper::updateConfig(const Config& config, ReconfigureReport* report) {
  const Status valid = config.isValid();
  if (!valid) return valid;
  ReconfigureReport local;
  ReconfigureReport& out = report != nullptr ? *report : local;
  out = ReconfigureReport();
  const bool new_grid = config.database.fusion_voxel_size_m != config_.database.fusion_voxel_size_m;
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
  if (new_grid && database_.size() > 0) fuseAgainAtNewGrid(&out);
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
  out.object_ids.assign(detections.size(), -1);
  out.drop_reasons.assign(detections.size(), std::string());

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
    out.drop_reasons.assign(detections.size(), "keyframe skipped: waiting for gravity");
    out.times.total_ms = msSince(start);
    return Status::Ok();
  }

  const KeptDetections kept = keepDetections(frame, detections, label, &out);
  // Eq. 1: one cloud per detection, back-projected once for the whole frame.
  Clock::time_point t = Clock::now();
  const KeyframeClouds clouds = prepareKeyframe(frame, kept, label, &out);
  out.times.extraction_ms = msSince(t);
  std::vector<SingleView> views = runSingleViews(frame, kept, clouds);
  if (cancelled()) {
    --keyframes_;  // nothing of it is in the map
    return Status::Error(label + ": cancelled");
  }
  fuseKeyframe(frame, keyframe, kept, label, clouds.depth_view, &views, &out);
  recordKeyframe(frame, keyframe, clouds.floor_layer_m, out.depth_fault, &views);
  noteDropReasons(&out);
  out.times.total_ms = msSince(start);
  return Status::Ok();
}

void ObjectMapper::noteDropReasons(KeyframeReport* out) const {
  // A mapped detection has no reason; an unmapped one of a fault keyframe without its own, that.
  for (size_t i = 0; i < out->drop_reasons.size(); ++i) {
    if (out->object_ids[i] >= 0) out->drop_reasons[i].clear();
    if (out->object_ids[i] < 0 && out->drop_reasons[i].empty() && out->depth_fault) {
      out->drop_reasons[i] = "keyframe taken for a sensor or SLAM fault";
    }
  }
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
      warnDetection(label, i, detection, "score is not a probability in [0, 1], skipped", out);
      continue;
    }
    if (!(detection.score >= config_.min_probability)) {
      out->drop_reasons[i] = "score under min_probability (lambda)";
      continue;
    }
    ++out->above_threshold;
    Detection2D named = detection;
    if (!nameClass(&named)) {
      warnDetection(label, i, detection, "unknown class (not a COCO class name), skipped", out);
      continue;
    }
    std::string problem;
    if (!boxLeavesBackground(frame, named, &problem)) {
      warnDetection(label, i, detection, problem, out);
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
                                                           KeyframeReport* out) {
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
    clouds.clouds_D = extractClouds(frame, kept, label, out);
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
                                                    KeyframeReport* out) const {
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
      warnDetection(label, kept.index[k], detections[k],
                    status ? std::string("extraction failed") : status.message(), out);
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
    const Clock::time_point start = Clock::now();
    views[k].status =
        runSingleView(clouds_D[k], frame.T_W_D, context, &views[k].observation, &views[k].times);
    views[k].wall_ms = msSince(start);
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

int ObjectMapper::threadCount() const { return poolSize(config_); }

}  // namespace mvod
