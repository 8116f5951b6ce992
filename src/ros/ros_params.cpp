#include "multiview_object_detection/ros/ros_params.h"

#include <ros/package.h>

#include <vector>

#include "multiview_object_detection/io/map_folder.h"
#include "multiview_object_detection/io/map_path.h"

namespace mvod {
namespace {

// Reads parameters of one namespace: nh.param(name, x, x), the current value as the default. A
// parameter that is set but has the wrong type would silently keep it; it is reported instead.
class ParamReader {
 public:
  ParamReader(const ros::NodeHandle& nh, ParamErrors* errors) : nh_(nh), errors_(errors) {}

  template <typename T>
  void read(const std::string& name, T* value) const {
    if (nh_.hasParam(name)) {
      T parsed = *value;
      if (!nh_.getParam(name, parsed)) {
        error("parameter " + nh_.resolveName(name) + " has the wrong type");
        return;
      }
    }
    nh_.param(name, *value, *value);
  }

  // Narrower numeric fields (float, ...) go through a double.
  template <typename T>
  void readNumber(const std::string& name, T* value) const {
    double number = static_cast<double>(*value);
    read(name, &number);
    *value = static_cast<T>(number);
  }

  void readVector3(const std::string& name, Eigen::Vector3d* value) const {
    std::vector<double> list{value->x(), value->y(), value->z()};
    read(name, &list);
    if (list.size() != 3) {
      error("parameter " + nh_.resolveName(name) + " must be a list of 3 numbers");
      return;
    }
    *value = Eigen::Vector3d(list[0], list[1], list[2]);
  }

  bool has(const std::string& name) const { return nh_.hasParam(name); }
  void error(const std::string& message) const {
    if (errors_ != nullptr) errors_->push_back(message);
  }

 private:
  const ros::NodeHandle& nh_;
  ParamErrors* errors_;
};

ros::NodeHandle child(const ros::NodeHandle& nh, const std::string& ns) {
  return ros::NodeHandle(nh, ns);
}

}  // namespace

ObjectCloudExtractor::Config getObjectCloudExtractorConfigFromRosParam(
    const ros::NodeHandle& nh_extractor, const ObjectCloudExtractor::Config& start,
    ParamErrors* errors) {
  const ParamReader p(nh_extractor, errors);
  ObjectCloudExtractor::Config c = start;
  p.read("min_valid_depth_m", &c.min_valid_depth_m);
  p.read("max_valid_depth_m", &c.max_valid_depth_m);
  p.read("mask_erosion_px", &c.mask_erosion_px);
  p.read("pixel_stride", &c.pixel_stride);
  p.readNumber("near_sampling_leaf_m", &c.near_sampling_leaf_m);
  p.read("min_consistent_neighbours", &c.min_consistent_neighbours);
  p.read("max_depth_edge_margin_px", &c.max_depth_edge_margin_px);
  p.readNumber("consistency_tolerance_m", &c.consistency_tolerance_m);
  p.readNumber("depth_step_per_m2", &c.depth_step_per_m2);
  return c;
}

PointCloudFilter::Config getPointCloudFilterConfigFromRosParam(
    const ros::NodeHandle& nh_filter, const PointCloudFilter::Config& start, ParamErrors* errors) {
  const ParamReader p(nh_filter, errors);
  PointCloudFilter::Config c = start;
  p.read("enable", &c.enable);
  p.read("voxel_leaf_size_m", &c.voxel_leaf_size_m);
  p.read("min_depth_m", &c.min_depth_m);
  p.read("max_depth_m", &c.max_depth_m);
  // Before outlier_removal: statistical_outlier_removal true / false (older configs).
  if (p.has("statistical_outlier_removal")) {
    bool statistical = c.outlier_removal.rfind("statistical", 0) == 0;
    p.read("statistical_outlier_removal", &statistical);
    if (!statistical) {
      c.outlier_removal = "none";
    } else if (c.outlier_removal.rfind("statistical", 0) != 0) {
      c.outlier_removal = "statistical_centres";
    }
  }
  p.read("outlier_removal", &c.outlier_removal);
  p.read("sor_mean_k", &c.sor_mean_k);
  p.read("sor_stddev_mul", &c.sor_stddev_mul);
  p.read("min_voxel_neighbours", &c.min_voxel_neighbours);
  return c;
}

LccpSegmenter::Config getLccpSegmenterConfigFromRosParam(const ros::NodeHandle& nh_lccp,
                                                         const LccpSegmenter::Config& start,
                                                         ParamErrors* errors) {
  const ParamReader p(nh_lccp, errors);
  LccpSegmenter::Config c = start;
  p.read("enable", &c.enable);
  p.read("implementation", &c.implementation);
  p.read("voxel_resolution_m", &c.voxel_resolution_m);
  p.read("seed_resolution_m", &c.seed_resolution_m);
  p.read("spatial_importance", &c.spatial_importance);
  p.read("normal_importance", &c.normal_importance);
  p.read("log_depth_transform", &c.log_depth_transform);
  p.read("concavity_tolerance_deg", &c.concavity_tolerance_deg);
  p.read("smoothness_threshold", &c.smoothness_threshold);
  p.read("min_segment_size", &c.min_segment_size);
  p.read("use_extended_convexity", &c.use_extended_convexity);
  p.read("use_sanity_criterion", &c.use_sanity_criterion);
  p.read("min_points", &c.min_points);
  return c;
}

SegmentSelector::Config getSegmentSelectorConfigFromRosParam(const ros::NodeHandle& nh_private,
                                                             const SegmentSelector::Config& start,
                                                             ParamErrors* errors) {
  SegmentSelector::Config c = start;
  ParamReader(child(nh_private, "lccp"), errors).read("selection", &c.selection);
  const ros::NodeHandle nh_selection = child(nh_private, "selection");
  const ParamReader p(nh_selection, errors);
  p.readNumber("core_box_fraction", &c.core_box_fraction);
  p.readNumber("core_mask_erosion", &c.core_mask_erosion);
  p.readNumber("adjacency_distance_m", &c.adjacency_distance_m);
  p.read("ring_px", &c.ring_px);
  p.readNumber("prior_size_slack", &c.prior_size_slack);
  p.readNumber("min_ring_share", &c.min_ring_share);
  p.readNumber("resting_distance_m", &c.resting_distance_m);
  p.readNumber("resting_min_share", &c.resting_min_share);
  p.readNumber("resting_edge_margin_m", &c.resting_edge_margin_m);
  p.readNumber("fallback_min_share", &c.fallback_min_share);
  p.readNumber("top_clearance_m", &c.top_clearance_m);
  p.readNumber("top_min_share", &c.top_min_share);
  p.readNumber("top_crossing_share", &c.top_crossing_share);
  p.readNumber("support_max_tilt_deg", &c.support_max_tilt_deg);
  return c;
}

FloorEstimator::Config getFloorEstimatorConfigFromRosParam(const ros::NodeHandle& nh_floor,
                                                           const FloorEstimator::Config& start,
                                                           ParamErrors* errors) {
  const ParamReader p(nh_floor, errors);
  FloorEstimator::Config c = start;
  p.read("enable", &c.enable);
  p.readNumber("clearance_m", &c.clearance_m);
  p.readNumber("clearance_per_m2", &c.clearance_per_m2);
  p.readNumber("grounding_distance_m", &c.grounding_distance_m);
  return c;
}

ManhattanFrameEstimator::Config getManhattanFrameConfigFromRosParam(
    const ros::NodeHandle& nh_box, const ManhattanFrameEstimator::Config& start,
    ParamErrors* errors) {
  const ParamReader p(nh_box, errors);
  ManhattanFrameEstimator::Config c = start;
  p.read("inlier_angle_deg", &c.inlier_angle_deg);
  p.read("normal_radius_m", &c.normal_radius_m);
  p.read("max_normals", &c.max_normals);
  p.read("gravity_constrained", &c.gravity_constrained);
  return c;
}

BoxEstimator::Config getBoxEstimatorConfigFromRosParam(const ros::NodeHandle& nh_box,
                                                       const BoxEstimator::Config& start,
                                                       ParamErrors* errors) {
  const ParamReader p(nh_box, errors);
  BoxEstimator::Config c = start;
  c.manhattan = getManhattanFrameConfigFromRosParam(nh_box, start.manhattan, errors);
  p.read("min_points", &c.min_points);
  p.readNumber("extent_trim_fraction", &c.extent_trim_fraction);
  p.readNumber("depth_step_per_m2", &c.depth_step_per_m2);
  p.readNumber("footprint_yaw_area_ratio", &c.footprint_yaw_area_ratio);
  p.readNumber("outline_cell_m", &c.outline_cell_m);
  p.read("normal_estimation", &c.normal_estimation);
  return c;
}

AmodalCompletion::Config getAmodalCompletionConfigFromRosParam(
    const ros::NodeHandle& nh_amodal, const AmodalCompletion::Config& start, ParamErrors* errors) {
  const ParamReader p(nh_amodal, errors);
  AmodalCompletion::Config c = start;
  p.read("enable", &c.enable);
  p.readNumber("cell_size_m", &c.cell_size_m);
  p.readNumber("max_thin_ratio", &c.max_thin_ratio);
  p.readNumber("free_margin_m", &c.free_margin_m);
  p.readNumber("max_free_share", &c.max_free_share);
  p.readNumber("min_free_ratio", &c.min_free_ratio);
  p.read("min_in_view", &c.min_in_view);
  p.read("min_observations", &c.min_observations);
  return c;
}

ExistenceModel::Config getExistenceModelConfigFromRosParam(const ros::NodeHandle& nh_existence,
                                                           const ExistenceModel::Config& start,
                                                           ParamErrors* errors) {
  const ParamReader p(nh_existence, errors);
  ExistenceModel::Config c = start;
  p.read("enable", &c.enable);
  p.read("detected_log_odds", &c.detected_log_odds);
  p.read("missed_log_odds", &c.missed_log_odds);
  p.read("missed_floor_log_odds", &c.missed_floor_log_odds);
  p.read("seen_through_log_odds", &c.seen_through_log_odds);
  p.read("min_log_odds", &c.min_log_odds);
  p.read("max_log_odds", &c.max_log_odds);
  p.read("remove_below", &c.remove_below);
  p.read("sample_voxels", &c.sample_voxels);
  p.read("min_voxels_in_view", &c.min_voxels_in_view);
  p.read("min_in_view_share", &c.min_in_view_share);
  p.read("seen_through_share", &c.seen_through_share);
  p.read("min_detected_share", &c.min_detected_share);
  p.read("min_votes_for_share", &c.min_votes_for_share);
  p.read("fade_max_detected", &c.fade_max_detected);
  p.read("free_margin_m", &c.free_margin_m);
  p.read("max_depth_m", &c.max_depth_m);
  return c;
}

ObjectDatabase::Config getObjectDatabaseConfigFromRosParam(const ros::NodeHandle& nh_database,
                                                           const ObjectDatabase::Config& start,
                                                           ParamErrors* errors) {
  const ParamReader p(nh_database, errors);
  ObjectDatabase::Config c = start;
  p.read("fusion_voxel_size_m", &c.fusion_voxel_size_m);
  p.read("no_fusion_within_keyframe", &c.no_fusion_within_keyframe);
  p.read("disable_fusion", &c.disable_fusion);
  p.read("fusion", &c.fusion);
  p.readNumber("min_overlap_to_fuse", &c.min_overlap_to_fuse);
  p.read("same_class_overlap_voxels", &c.same_class_overlap_voxels);
  p.readNumber("surface_band_m", &c.surface_band_m);
  p.readNumber("view_consensus_m", &c.view_consensus_m);
  c.amodal =
      getAmodalCompletionConfigFromRosParam(child(nh_database, "amodal"), start.amodal, errors);
  c.existence =
      getExistenceModelConfigFromRosParam(child(nh_database, "existence"), start.existence, errors);
  return c;
}

PriorSizeFilter::Config getPriorSizeFilterConfigFromRosParam(const ros::NodeHandle& nh_prior_filter,
                                                             const PriorSizeFilter::Config& start,
                                                             ParamErrors* errors) {
  const ParamReader p(nh_prior_filter, errors);
  PriorSizeFilter::Config c = start;
  p.read("enable", &c.enable);
  p.read("volume_min_ratio", &c.volume_min_ratio);
  p.read("volume_max_ratio", &c.volume_max_ratio);
  p.read("edge_min_ratio", &c.edge_min_ratio);
  p.read("keep_classes_without_prior", &c.keep_classes_without_prior);
  return c;
}

IntersectionFilter::Config getIntersectionFilterConfigFromRosParam(
    const ros::NodeHandle& nh_intersection_filter, const IntersectionFilter::Config& start,
    ParamErrors* errors) {
  const ParamReader p(nh_intersection_filter, errors);
  IntersectionFilter::Config c = start;
  p.read("enable", &c.enable);
  p.read("volume_ratio_threshold", &c.volume_ratio_threshold);
  p.readNumber("duplicate_ratio", &c.duplicate_ratio);
  p.read("merge_duplicates", &c.merge_duplicates);
  p.readNumber("container_support_ratio", &c.container_support_ratio);
  p.readNumber("flat_top_clearance_m", &c.flat_top_clearance_m);
  return c;
}

GravityEstimator::Config getGravityEstimatorConfigFromRosParam(
    const ros::NodeHandle& nh_gravity, const GravityEstimator::Config& start, ParamErrors* errors) {
  const ParamReader p(nh_gravity, errors);
  GravityEstimator::Config c = start;
  p.read("plane_distance_threshold_m", &c.plane_distance_threshold_m);
  p.read("ransac_iterations", &c.ransac_iterations);
  p.read("max_tilt_from_camera_up_deg", &c.max_tilt_from_camera_up_deg);
  p.read("min_plane_fraction", &c.min_plane_fraction);
  p.read("voxel_size_m", &c.voxel_size_m);
  return c;
}

KeyframeHistory::Config getKeyframeHistoryConfigFromRosParam(const ros::NodeHandle& nh_corrections,
                                                             const KeyframeHistory::Config& start,
                                                             ParamErrors* errors) {
  const ParamReader p(nh_corrections, errors);
  KeyframeHistory::Config c = start;
  p.read("enable", &c.enable);
  p.read("stamp_tolerance_s", &c.stamp_tolerance_s);
  p.read("max_memory_mb", &c.max_memory_mb);
  if (p.has("max_keyframes_with_depth")) {
    p.error("parameter " + nh_corrections.resolveName("max_keyframes_with_depth") +
            " was replaced by max_memory_mb (the history's memory bound in MB): remove it");
  }
  return c;
}

ObjectMapper::Config getObjectMapperConfigFromRosParam(const ros::NodeHandle& nh_private,
                                                       ParamErrors* errors) {
  const ParamReader p(nh_private, errors);
  ObjectMapper::Config m;
  // paper_method first (Eq. 2 largest segment, Eq. 7 literal fusion, PCL's LCCP, ...): every single
  // setting read below starts from it, so one set as a parameter overrides it.
  bool paper_method = false;
  p.read("paper_method", &paper_method);
  if (paper_method) m.usePaperMethod();
  p.read("min_probability", &m.min_probability);
  p.read("min_object_points", &m.min_object_points);
  p.read("num_threads", &m.num_threads);
  const auto ns = [&nh_private](const std::string& name) { return child(nh_private, name); };
  m.extractor = getObjectCloudExtractorConfigFromRosParam(ns("extractor"), m.extractor, errors);
  m.filter = getPointCloudFilterConfigFromRosParam(ns("filter"), m.filter, errors);
  m.lccp = getLccpSegmenterConfigFromRosParam(ns("lccp"), m.lccp, errors);
  m.selection = getSegmentSelectorConfigFromRosParam(nh_private, m.selection, errors);
  m.floor = getFloorEstimatorConfigFromRosParam(ns("floor"), m.floor, errors);
  m.box = getBoxEstimatorConfigFromRosParam(ns("box"), m.box, errors);
  m.database = getObjectDatabaseConfigFromRosParam(ns("database"), m.database, errors);
  m.prior_filter = getPriorSizeFilterConfigFromRosParam(ns("prior_filter"), m.prior_filter, errors);
  m.intersection_filter = getIntersectionFilterConfigFromRosParam(ns("intersection_filter"),
                                                                  m.intersection_filter, errors);
  m.gravity = getGravityEstimatorConfigFromRosParam(ns("gravity"), m.gravity, errors);
  m.corrections = getKeyframeHistoryConfigFromRosParam(ns("corrections"), m.corrections, errors);
  return m;
}

KeyframeSelector::Config getKeyframeSelectorConfigFromRosParam(const ros::NodeHandle& nh_private,
                                                               ParamErrors* errors) {
  const ParamReader p(nh_private, errors);
  KeyframeSelector::Config c;
  std::string mode = KeyframeSelector::modeName(c.mode);
  if (c.mode == KeyframeSelector::Mode::kExternal) mode = "topic";
  p.read("keyframe_mode", &mode);
  const Status parsed = KeyframeSelector::modeFromString(mode, &c.mode);
  if (!parsed) p.error("parameter keyframe_mode: " + parsed.message());
  p.read("keyframe_every_n", &c.every_n);
  p.read("keyframe_min_translation_m", &c.min_translation_m);
  p.read("keyframe_min_rotation_deg", &c.min_rotation_deg);
  return c;
}

SegmenterOptions getSegmenterOptionsFromRosParam(const ros::NodeHandle& nh_private,
                                                 ParamErrors* errors) {
  const ParamReader p(nh_private, errors);
  SegmenterOptions c;
  p.read("model_dir", &c.model_dir);
  p.readNumber("score_threshold", &c.score_threshold);
  p.read("detector_backend", &c.backend);
  p.readNumber("nms_threshold", &c.nms_threshold);
  p.readNumber("mask_threshold", &c.mask_threshold);
  p.read("yolo_seg_model", &c.yolo_seg_model);
  p.read("yolo_seg_labels", &c.yolo_seg_labels);
  p.read("yolo_seg_input_px", &c.yolo_seg_input_px);
  p.read("fastestdet_model", &c.fastestdet_model);
  p.read("fastestdet_labels", &c.fastestdet_labels);
  p.read("maskrcnn_weights", &c.maskrcnn_weights);
  p.read("maskrcnn_graph", &c.maskrcnn_graph);
  p.read("maskrcnn_labels", &c.maskrcnn_labels);
  return c;
}

std::string defaultAutosaveName(const std::string& node_namespace) {
  std::string name = node_namespace;
  while (!name.empty() && name.front() == '/') name.erase(name.begin());
  for (char& c : name) {
    if (c == '/') c = '.';
  }
  return (name.empty() ? std::string("object_detection") : name) + ".autosave" +
         kMapFolderExtension;
}

ObjectDetectionRosConfig getObjectDetectionConfigFromRosParam(const ros::NodeHandle& nh_private,
                                                              ParamErrors* errors) {
  const ParamReader p(nh_private, errors);
  ObjectDetectionRosConfig cfg;
  p.read("world_frame", &cfg.world_frame);
  p.read("output_frame", &cfg.output_frame);
  p.read("camera_frame", &cfg.camera_frame);
  p.read("depth_registered", &cfg.depth_registered);
  p.read("queue_size", &cfg.queue_size);
  p.read("exact_sync", &cfg.exact_sync);
  p.read("input_min_rate_hz", &cfg.input_min_rate_hz);
  p.read("input_timeout_s", &cfg.input_timeout_s);
  p.read("diagnostic_period", &cfg.diagnostic_period);
  p.read("pose_source", &cfg.pose_source);
  p.read("tf_timeout_s", &cfg.tf_timeout_s);
  p.read("pose_max_time_diff_s", &cfg.pose_max_time_diff_s);
  p.read("gravity_source", &cfg.gravity_source);
  p.readVector3("gravity_down", &cfg.gravity_down_W);
  p.read("gravity_frame", &cfg.gravity_frame);
  cfg.keyframes = getKeyframeSelectorConfigFromRosParam(nh_private, errors);

  std::string detector = "auto";
  p.read("detector", &detector);
  cfg.segmenter = getSegmenterOptionsFromRosParam(nh_private, errors);
  cfg.segmenter.detector = detector;
  cfg.detector = resolveAutoDetector(cfg.segmenter);
  cfg.detector_auto = detector == "auto";
  // Thresholds not given: the detector's own (detectorThresholds).
  cfg.segmenter.detector = cfg.detector;
  cfg.segmenter = cfg.segmenter.withDetectorDefaults();
  p.read("detections_max_age_s", &cfg.detections_max_age_s);
  p.read("max_detections_per_frame", &cfg.max_detections_per_frame);
  p.read("map_directory", &cfg.map_directory);
  p.read("service_timeout_s", &cfg.service_timeout_s);
  p.read("allow_any_map_path", &cfg.allow_any_map_path);
  p.read("autosave_period_s", &cfg.autosave_period_s);
  p.read("autosave_path", &cfg.autosave_path);
  if (cfg.autosave_path.empty()) cfg.autosave_path = defaultAutosaveName(nh_private.getNamespace());
  p.read("load_map_on_start", &cfg.load_map_on_start);
  if (cfg.map_directory.empty()) cfg.map_directory = defaultMapDirectory();
  p.read("processing_queue_size", &cfg.processing_queue_size);
  p.read("processing_queue_max_mb", &cfg.processing_queue_max_mb);
  p.read("refine_every_n_keyframes", &cfg.refine_every_n_keyframes);
  p.read("priors_file", &cfg.priors_file);
  if (cfg.priors_file.empty()) {
    const std::string package = ros::package::getPath("multiview_object_detection");
    if (!package.empty()) cfg.priors_file = package + "/config/class_priors.yaml";
  }
  p.read("publish_object_cloud", &cfg.publish_object_cloud);

  cfg.mapper = getObjectMapperConfigFromRosParam(nh_private, errors);
  if (!nh_private.hasParam("min_probability")) {
    cfg.mapper.min_probability = detectorThresholds(cfg.detector).min_probability;
  }
  cfg.mapper.gravity_down_W = cfg.mapperConfig().gravity_down_W;
  return cfg;
}

}  // namespace mvod
