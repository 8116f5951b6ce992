// The node's parameters are read here and nowhere else, one reader per Config
// (voxblox_ros/ros_params.h). Each reader takes the node handle of the Config's own namespace and
// the values to start from (the struct's defaults, or the paper's method), and sets a field only
// where a parameter is given, so the starting value stays the default. Values are not validated
// here: call isValid() on the result. A parameter of the wrong type keeps its starting value and is
// listed in *errors when errors is given.
#pragma once

#include <ros/node_handle.h>

#include <string>
#include <vector>

#include "multiview_object_detection/ros/object_detection_ros_config.h"

namespace mvod {

using ParamErrors = std::vector<std::string>;

// Core stages, each in its own namespace of the node's private one (the name in parentheses).
ObjectCloudExtractor::Config getObjectCloudExtractorConfigFromRosParam(
    const ros::NodeHandle& nh_extractor, const ObjectCloudExtractor::Config& start,
    ParamErrors* errors);  // (extractor)
PointCloudFilter::Config getPointCloudFilterConfigFromRosParam(
    const ros::NodeHandle& nh_filter, const PointCloudFilter::Config& start,
    ParamErrors* errors);  // (filter)
LccpSegmenter::Config getLccpSegmenterConfigFromRosParam(const ros::NodeHandle& nh_lccp,
                                                         const LccpSegmenter::Config& start,
                                                         ParamErrors* errors);  // (lccp)
// (selection; the method itself is lccp/selection, the choice among LCCP's segments)
SegmentSelector::Config getSegmentSelectorConfigFromRosParam(const ros::NodeHandle& nh_private,
                                                             const SegmentSelector::Config& start,
                                                             ParamErrors* errors);
FloorEstimator::Config getFloorEstimatorConfigFromRosParam(const ros::NodeHandle& nh_floor,
                                                           const FloorEstimator::Config& start,
                                                           ParamErrors* errors);  // (floor)
ManhattanFrameEstimator::Config getManhattanFrameConfigFromRosParam(
    const ros::NodeHandle& nh_box, const ManhattanFrameEstimator::Config& start,
    ParamErrors* errors);  // (box)
BoxEstimator::Config getBoxEstimatorConfigFromRosParam(const ros::NodeHandle& nh_box,
                                                       const BoxEstimator::Config& start,
                                                       ParamErrors* errors);  // (box)
AmodalCompletion::Config getAmodalCompletionConfigFromRosParam(
    const ros::NodeHandle& nh_amodal, const AmodalCompletion::Config& start,
    ParamErrors* errors);  // (database/amodal)
ExistenceModel::Config getExistenceModelConfigFromRosParam(
    const ros::NodeHandle& nh_existence, const ExistenceModel::Config& start,
    ParamErrors* errors);  // (database/existence)
ObjectDatabase::Config getObjectDatabaseConfigFromRosParam(const ros::NodeHandle& nh_database,
                                                           const ObjectDatabase::Config& start,
                                                           ParamErrors* errors);  // (database)
PriorSizeFilter::Config getPriorSizeFilterConfigFromRosParam(
    const ros::NodeHandle& nh_prior_filter, const PriorSizeFilter::Config& start,
    ParamErrors* errors);  // (prior_filter)
IntersectionFilter::Config getIntersectionFilterConfigFromRosParam(
    const ros::NodeHandle& nh_intersection_filter, const IntersectionFilter::Config& start,
    ParamErrors* errors);  // (intersection_filter)
GravityEstimator::Config getGravityEstimatorConfigFromRosParam(
    const ros::NodeHandle& nh_gravity, const GravityEstimator::Config& start,
    ParamErrors* errors);  // (gravity)
KeyframeHistory::Config getKeyframeHistoryConfigFromRosParam(const ros::NodeHandle& nh_corrections,
                                                             const KeyframeHistory::Config& start,
                                                             ParamErrors* errors);  // (corrections)
// The whole core: paper_method first (every setting read afterwards starts from the paper's), then
// min_probability, min_object_points, num_threads and every section above.
ObjectMapper::Config getObjectMapperConfigFromRosParam(const ros::NodeHandle& nh_private,
                                                       ParamErrors* errors);

// The node's own: keyframe_* (KeyframeSelector), the detector's options, and
// ObjectDetectionRosConfig with all of the above.
KeyframeSelector::Config getKeyframeSelectorConfigFromRosParam(const ros::NodeHandle& nh_private,
                                                               ParamErrors* errors);
SegmenterOptions getSegmenterOptionsFromRosParam(const ros::NodeHandle& nh_private,
                                                 ParamErrors* errors);
// The default autosave file of the node in `node_namespace` ("/robot1/object_detection" ->
// "robot1.object_detection.autosave.json").
std::string defaultAutosaveName(const std::string& node_namespace);

ObjectDetectionRosConfig getObjectDetectionConfigFromRosParam(const ros::NodeHandle& nh_private,
                                                              ParamErrors* errors = nullptr);

}  // namespace mvod
