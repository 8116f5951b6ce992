// All parameters of object_detection_node are read here and nowhere else
// (voxblox_ros/ros_params.h): nh_private.param(name, cfg.x, cfg.x), so the struct's defaults stay
// the defaults.
#pragma once

#include <ros/node_handle.h>

#include "multiview_object_detection/ros/object_detection_ros_config.h"

namespace mvod {

// Reads every parameter of the node (private namespace). Values are not validated here: call
// isValid() on the result. A parameter of the wrong type (e.g. a string for a number) keeps the
// default and is listed in *errors when errors is given.
ObjectDetectionRosConfig getObjectDetectionConfigFromRosParam(
    const ros::NodeHandle& nh_private, std::vector<std::string>* errors = nullptr);

}  // namespace mvod
