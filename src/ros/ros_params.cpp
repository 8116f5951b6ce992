#include "multiview_object_detection/ros/ros_params.h"

#include <ros/package.h>

#include <vector>

#include "multiview_object_detection/io/map_path.h"

namespace mvod {
namespace {

// nh.param(name, x, x): the current value is the default. A parameter that is set but has the
// wrong type would silently keep the default; report it instead.
template <typename T>
void readParam(const ros::NodeHandle& nh, const std::string& name, T* value,
               std::vector<std::string>* errors) {
  if (nh.hasParam(name)) {
    T parsed = *value;
    if (!nh.getParam(name, parsed)) {
      if (errors != nullptr) {
        errors->push_back("parameter " + nh.resolveName(name) + " has the wrong type");
      }
      return;
    }
  }
  nh.param(name, *value, *value);
}

// Narrower numeric fields (float, ...) go through a double.
template <typename T>
void readNumber(const ros::NodeHandle& nh, const std::string& name, T* value,
                std::vector<std::string>* errors) {
  double number = static_cast<double>(*value);
  readParam(nh, name, &number, errors);
  *value = static_cast<T>(number);
}

void readVector3(const ros::NodeHandle& nh, const std::string& name, Eigen::Vector3d* value,
                 std::vector<std::string>* errors) {
  std::vector<double> list{value->x(), value->y(), value->z()};
  readParam(nh, name, &list, errors);
  if (list.size() != 3) {
    if (errors != nullptr) {
      errors->push_back("parameter " + nh.resolveName(name) + " must be a list of 3 numbers");
    }
    return;
  }
  *value = Eigen::Vector3d(list[0], list[1], list[2]);
}

}  // namespace

ObjectDetectionRosConfig getObjectDetectionConfigFromRosParam(const ros::NodeHandle& nh_private,
                                                              std::vector<std::string>* errors) {
  const ros::NodeHandle& nh = nh_private;
  std::vector<std::string>* e = errors;
  ObjectDetectionRosConfig cfg;

  // Node.
  readParam(nh, "world_frame", &cfg.world_frame, e);
  readParam(nh, "camera_frame", &cfg.camera_frame, e);
  readParam(nh, "depth_registered", &cfg.depth_registered, e);
  readParam(nh, "queue_size", &cfg.queue_size, e);
  readParam(nh, "exact_sync", &cfg.exact_sync, e);
  readParam(nh, "pose_source", &cfg.pose_source, e);
  readParam(nh, "tf_timeout_s", &cfg.tf_timeout_s, e);
  readParam(nh, "pose_max_time_diff_s", &cfg.pose_max_time_diff_s, e);
  readParam(nh, "gravity_source", &cfg.gravity_source, e);
  readVector3(nh, "gravity_down", &cfg.gravity_down_W, e);
  readParam(nh, "gravity_frame", &cfg.gravity_frame, e);

  std::string keyframe_mode = KeyframeSelector::modeName(cfg.keyframes.mode);
  if (cfg.keyframes.mode == KeyframeSelector::Mode::kExternal) keyframe_mode = "topic";
  readParam(nh, "keyframe_mode", &keyframe_mode, e);
  const Status mode = KeyframeSelector::modeFromString(keyframe_mode, &cfg.keyframes.mode);
  if (!mode && errors != nullptr) errors->push_back("parameter keyframe_mode: " + mode.message());
  readParam(nh, "keyframe_every_n", &cfg.keyframes.every_n, e);
  readParam(nh, "keyframe_min_translation_m", &cfg.keyframes.min_translation_m, e);
  readParam(nh, "keyframe_min_rotation_deg", &cfg.keyframes.min_rotation_deg, e);

  // Detector.
  readParam(nh, "detector", &cfg.detector, e);
  SegmenterOptions& seg = cfg.segmenter;
  readParam(nh, "model_dir", &seg.model_dir, e);
  readNumber(nh, "score_threshold", &seg.score_threshold, e);
  readParam(nh, "detector_backend", &seg.backend, e);
  readNumber(nh, "nms_threshold", &seg.nms_threshold, e);
  readNumber(nh, "mask_threshold", &seg.mask_threshold, e);
  readParam(nh, "fastestdet_model", &seg.fastestdet_model, e);
  readParam(nh, "fastestdet_labels", &seg.fastestdet_labels, e);
  readParam(nh, "maskrcnn_weights", &seg.maskrcnn_weights, e);
  readParam(nh, "maskrcnn_graph", &seg.maskrcnn_graph, e);
  readParam(nh, "maskrcnn_labels", &seg.maskrcnn_labels, e);
  readParam(nh, "detections_max_age_s", &cfg.detections_max_age_s, e);
  readParam(nh, "max_detections_per_frame", &cfg.max_detections_per_frame, e);
  readParam(nh, "map_directory", &cfg.map_directory, e);
  readParam(nh, "allow_any_map_path", &cfg.allow_any_map_path, e);
  if (cfg.map_directory.empty()) cfg.map_directory = defaultMapDirectory();

  readParam(nh, "processing_queue_size", &cfg.processing_queue_size, e);
  readParam(nh, "refine_every_n_keyframes", &cfg.refine_every_n_keyframes, e);
  readParam(nh, "priors_file", &cfg.priors_file, e);
  if (cfg.priors_file.empty()) {
    const std::string package = ros::package::getPath("multiview_object_detection");
    if (!package.empty()) cfg.priors_file = package + "/config/class_priors.yaml";
  }
  readParam(nh, "publish_object_cloud", &cfg.publish_object_cloud, e);

  // Core: every ObjectMapper::Config field, section/field.
  ObjectMapper::Config& m = cfg.mapper;
  // paper_method first (Eq. 2 largest segment, Eq. 7 literal fusion, PCL's LCCP, ...): every single
  // setting read below starts from it, so one set as a parameter overrides it wherever it is read.
  bool paper_method = false;
  readParam(nh, "paper_method", &paper_method, e);
  if (paper_method) m.usePaperMethod();
  readParam(nh, "min_probability", &m.min_probability, e);
  readParam(nh, "min_object_points", &m.min_object_points, e);
  readParam(nh, "num_threads", &m.num_threads, e);

  readParam(nh, "extractor/min_valid_depth_m", &m.extractor.min_valid_depth_m, e);
  readParam(nh, "extractor/max_valid_depth_m", &m.extractor.max_valid_depth_m, e);
  readParam(nh, "extractor/mask_erosion_px", &m.extractor.mask_erosion_px, e);
  readParam(nh, "extractor/pixel_stride", &m.extractor.pixel_stride, e);
  readParam(nh, "extractor/min_consistent_neighbours", &m.extractor.min_consistent_neighbours, e);
  readNumber(nh, "extractor/consistency_tolerance_m", &m.extractor.consistency_tolerance_m, e);
  readNumber(nh, "extractor/depth_step_per_m2", &m.extractor.depth_step_per_m2, e);

  readParam(nh, "filter/enable", &m.filter.enable, e);
  readParam(nh, "filter/voxel_leaf_size_m", &m.filter.voxel_leaf_size_m, e);
  readParam(nh, "filter/min_depth_m", &m.filter.min_depth_m, e);
  readParam(nh, "filter/max_depth_m", &m.filter.max_depth_m, e);
  // Before outlier_removal: statistical_outlier_removal true / false (older configs).
  if (nh.hasParam("filter/statistical_outlier_removal")) {
    bool statistical = m.filter.outlier_removal.rfind("statistical", 0) == 0;
    readParam(nh, "filter/statistical_outlier_removal", &statistical, e);
    if (!statistical) {
      m.filter.outlier_removal = "none";
    } else if (m.filter.outlier_removal.rfind("statistical", 0) != 0) {
      m.filter.outlier_removal = "statistical_centres";
    }
  }
  readParam(nh, "filter/sor_mean_k", &m.filter.sor_mean_k, e);
  readParam(nh, "filter/sor_stddev_mul", &m.filter.sor_stddev_mul, e);

  readParam(nh, "lccp/enable", &m.lccp.enable, e);
  readParam(nh, "lccp/voxel_resolution_m", &m.lccp.voxel_resolution_m, e);
  readParam(nh, "lccp/seed_resolution_m", &m.lccp.seed_resolution_m, e);
  readParam(nh, "lccp/spatial_importance", &m.lccp.spatial_importance, e);
  readParam(nh, "lccp/normal_importance", &m.lccp.normal_importance, e);
  readParam(nh, "lccp/log_depth_transform", &m.lccp.log_depth_transform, e);
  readParam(nh, "lccp/concavity_tolerance_deg", &m.lccp.concavity_tolerance_deg, e);
  readParam(nh, "lccp/smoothness_threshold", &m.lccp.smoothness_threshold, e);
  readParam(nh, "lccp/min_segment_size", &m.lccp.min_segment_size, e);
  readParam(nh, "lccp/use_extended_convexity", &m.lccp.use_extended_convexity, e);
  readParam(nh, "lccp/use_sanity_criterion", &m.lccp.use_sanity_criterion, e);
  readParam(nh, "lccp/min_points", &m.lccp.min_points, e);
  readParam(nh, "filter/outlier_removal", &m.filter.outlier_removal, e);
  readParam(nh, "filter/min_voxel_neighbours", &m.filter.min_voxel_neighbours, e);
  readParam(nh, "lccp/selection", &m.selection.selection, e);
  readParam(nh, "lccp/implementation", &m.lccp.implementation, e);
  readNumber(nh, "selection/core_box_fraction", &m.selection.core_box_fraction, e);
  readNumber(nh, "selection/core_mask_erosion", &m.selection.core_mask_erosion, e);
  readNumber(nh, "selection/adjacency_distance_m", &m.selection.adjacency_distance_m, e);
  readParam(nh, "selection/ring_px", &m.selection.ring_px, e);
  readNumber(nh, "selection/prior_size_slack", &m.selection.prior_size_slack, e);
  readNumber(nh, "selection/min_ring_share", &m.selection.min_ring_share, e);
  readNumber(nh, "selection/resting_distance_m", &m.selection.resting_distance_m, e);
  readNumber(nh, "selection/resting_min_share", &m.selection.resting_min_share, e);
  readNumber(nh, "selection/resting_edge_margin_m", &m.selection.resting_edge_margin_m, e);
  readNumber(nh, "selection/fallback_min_share", &m.selection.fallback_min_share, e);
  readNumber(nh, "selection/top_clearance_m", &m.selection.top_clearance_m, e);
  readNumber(nh, "selection/top_min_share", &m.selection.top_min_share, e);
  readNumber(nh, "selection/top_crossing_share", &m.selection.top_crossing_share, e);
  readNumber(nh, "selection/support_max_tilt_deg", &m.selection.support_max_tilt_deg, e);
  readParam(nh, "floor/enable", &m.floor.enable, e);
  readNumber(nh, "floor/clearance_m", &m.floor.clearance_m, e);
  readNumber(nh, "floor/clearance_per_m2", &m.floor.clearance_per_m2, e);
  readNumber(nh, "floor/grounding_distance_m", &m.floor.grounding_distance_m, e);

  readParam(nh, "box/inlier_angle_deg", &m.box.manhattan.inlier_angle_deg, e);
  readParam(nh, "box/normal_radius_m", &m.box.manhattan.normal_radius_m, e);
  readParam(nh, "box/max_normals", &m.box.manhattan.max_normals, e);
  readParam(nh, "box/gravity_constrained", &m.box.manhattan.gravity_constrained, e);
  readParam(nh, "box/min_points", &m.box.min_points, e);
  readNumber(nh, "box/extent_trim_fraction", &m.box.extent_trim_fraction, e);
  readNumber(nh, "box/depth_step_per_m2", &m.box.depth_step_per_m2, e);
  readNumber(nh, "box/footprint_yaw_area_ratio", &m.box.footprint_yaw_area_ratio, e);
  readNumber(nh, "box/outline_cell_m", &m.box.outline_cell_m, e);
  readParam(nh, "box/normal_estimation", &m.box.normal_estimation, e);

  readParam(nh, "database/fusion_voxel_size_m", &m.database.fusion_voxel_size_m, e);
  readParam(nh, "database/no_fusion_within_keyframe", &m.database.no_fusion_within_keyframe, e);
  readParam(nh, "database/disable_fusion", &m.database.disable_fusion, e);
  readParam(nh, "database/fusion", &m.database.fusion, e);
  readNumber(nh, "database/min_overlap_to_fuse", &m.database.min_overlap_to_fuse, e);
  readParam(nh, "database/same_class_overlap_voxels", &m.database.same_class_overlap_voxels, e);
  readNumber(nh, "database/surface_band_m", &m.database.surface_band_m, e);
  readParam(nh, "database/amodal/enable", &m.database.amodal.enable, e);
  readNumber(nh, "database/amodal/cell_size_m", &m.database.amodal.cell_size_m, e);
  readNumber(nh, "database/amodal/max_thin_ratio", &m.database.amodal.max_thin_ratio, e);
  readNumber(nh, "database/amodal/free_margin_m", &m.database.amodal.free_margin_m, e);
  readNumber(nh, "database/amodal/max_free_share", &m.database.amodal.max_free_share, e);
  readNumber(nh, "database/amodal/min_free_ratio", &m.database.amodal.min_free_ratio, e);
  readParam(nh, "database/amodal/min_in_view", &m.database.amodal.min_in_view, e);
  readParam(nh, "database/amodal/min_observations", &m.database.amodal.min_observations, e);

  readParam(nh, "prior_filter/enable", &m.prior_filter.enable, e);
  readParam(nh, "prior_filter/volume_min_ratio", &m.prior_filter.volume_min_ratio, e);
  readParam(nh, "prior_filter/volume_max_ratio", &m.prior_filter.volume_max_ratio, e);
  readParam(nh, "prior_filter/edge_min_ratio", &m.prior_filter.edge_min_ratio, e);
  readParam(nh, "prior_filter/keep_classes_without_prior",
            &m.prior_filter.keep_classes_without_prior, e);

  readParam(nh, "intersection_filter/enable", &m.intersection_filter.enable, e);
  readParam(nh, "intersection_filter/volume_ratio_threshold",
            &m.intersection_filter.volume_ratio_threshold, e);
  readNumber(nh, "intersection_filter/duplicate_ratio", &m.intersection_filter.duplicate_ratio, e);
  readParam(nh, "intersection_filter/merge_duplicates", &m.intersection_filter.merge_duplicates, e);
  readNumber(nh, "intersection_filter/container_support_ratio",
             &m.intersection_filter.container_support_ratio, e);

  readParam(nh, "gravity/plane_distance_threshold_m", &m.gravity.plane_distance_threshold_m, e);
  readParam(nh, "gravity/ransac_iterations", &m.gravity.ransac_iterations, e);
  readParam(nh, "gravity/max_tilt_from_camera_up_deg", &m.gravity.max_tilt_from_camera_up_deg, e);
  readParam(nh, "gravity/min_plane_fraction", &m.gravity.min_plane_fraction, e);
  readParam(nh, "gravity/voxel_size_m", &m.gravity.voxel_size_m, e);

  m.gravity_down_W = cfg.mapperConfig().gravity_down_W;
  return cfg;
}

}  // namespace mvod
