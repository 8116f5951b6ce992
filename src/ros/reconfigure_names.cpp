#include "multiview_object_detection/ros/reconfigure_names.h"

#include <boost/any.hpp>
#include <map>

namespace mvod {

std::string yamlParameterName(const std::string& reconfigure_name) {
  static const std::map<std::string, std::string> kNested = {
      {"database_fusion_voxel_size_m", "database/fusion_voxel_size_m"},
      {"database_disable_fusion", "database/disable_fusion"},
      {"database_existence_enable", "database/existence/enable"},
      {"database_existence_remove_below", "database/existence/remove_below"},
      {"prior_filter_enable", "prior_filter/enable"},
      {"prior_filter_volume_min_ratio", "prior_filter/volume_min_ratio"},
      {"prior_filter_volume_max_ratio", "prior_filter/volume_max_ratio"},
      {"prior_filter_edge_min_ratio", "prior_filter/edge_min_ratio"},
      {"intersection_filter_enable", "intersection_filter/enable"},
      {"intersection_filter_volume_ratio_threshold", "intersection_filter/volume_ratio_threshold"},
  };
  const auto found = kNested.find(reconfigure_name);
  return found == kNested.end() ? reconfigure_name : found->second;
}

void setYamlParameters(const ros::NodeHandle& nh_private,
                       const multiview_object_detection::ObjectDetectionConfig& values) {
  using multiview_object_detection::ObjectDetectionConfig;
  for (const auto& description : ObjectDetectionConfig::__getParamDescriptions__()) {
    const std::string yaml_name = yamlParameterName(description->name);
    if (yaml_name == description->name) continue;  // the server's own write is the YAML name
    boost::any value;
    description->getValue(values, value);
    if (value.type() == typeid(int)) {
      nh_private.setParam(yaml_name, boost::any_cast<int>(value));
    } else if (value.type() == typeid(double)) {
      nh_private.setParam(yaml_name, boost::any_cast<double>(value));
    } else if (value.type() == typeid(bool)) {
      nh_private.setParam(yaml_name, boost::any_cast<bool>(value));
    } else if (value.type() == typeid(std::string)) {
      nh_private.setParam(yaml_name, boost::any_cast<std::string>(value));
    }
  }
}

}  // namespace mvod
