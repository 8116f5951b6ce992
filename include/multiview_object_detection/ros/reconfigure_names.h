// One name per setting: dynamic_reconfigure names cannot hold '/', so the .cfg names the nested
// YAML parameters with '_' (database_fusion_voxel_size_m for database/fusion_voxel_size_m). The
// server writes the live values under its own names; these functions write them under the YAML
// names too, so that `rosparam get` shows the value in effect under the name the user set.
#pragma once

#include <multiview_object_detection/ObjectDetectionConfig.h>
#include <ros/node_handle.h>

#include <string>

namespace mvod {

// The YAML (ROS parameter) name of a dynamic_reconfigure parameter of cfg/ObjectDetection.cfg; a
// name without a nested YAML name is returned as it is.
std::string yamlParameterName(const std::string& reconfigure_name);

// Sets every reconfigurable value whose YAML name differs from its reconfigure name under the YAML
// name, in nh_private's namespace.
void setYamlParameters(const ros::NodeHandle& nh_private,
                       const multiview_object_detection::ObjectDetectionConfig& values);

}  // namespace mvod
