// The map file's field readers and writers, shared by the objects' and the keyframe history's
// parts of it (json_io.cpp, history_json.cpp). Private to the io library.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "multiview_object_detection/pipeline/types/common.h"
#include "multiview_object_detection/pipeline/types/map_limits.h"

namespace mvod {
namespace json_fields {

using nlohmann::json;

// Clouds are stored at 1 mm: finer than any sensor here and it keeps map files small.
inline double roundToMillimetre(float value) {
  return std::round(static_cast<double>(value) * 1000.0) / 1000.0;
}

inline json vectorToJson(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

inline json cloudToJson(const PointCloud& cloud) {
  json points = json::array();
  for (const Eigen::Vector3f& p : cloud) {
    points.push_back(json::array(
        {roundToMillimetre(p.x()), roundToMillimetre(p.y()), roundToMillimetre(p.z())}));
  }
  return points;
}

// Field readers: each names the field (path) it failed on.
inline Status fieldError(const std::string& path, const std::string& what) {
  return Status::Error("objects.json: " + path + ": " + what);
}

inline Status member(const json& parent, const std::string& path, const char* key,
                     const json** value) {
  const auto it = parent.find(key);
  if (it == parent.end()) return fieldError(path + key, "missing");
  *value = &*it;
  return Status::Ok();
}

inline Status readInt(const json& parent, const std::string& path, const char* key, int min_value,
                      int* out) {
  const json* value = nullptr;
  Status status = member(parent, path, key, &value);
  if (!status) return status;
  if (!value->is_number_integer()) return fieldError(path + key, "expected an integer");
  // An unsigned value above LLONG_MAX would wrap to a negative long long (2^64 - 1 -> -1).
  const bool huge = value->is_number_unsigned() &&
                    value->get<unsigned long long>() > std::numeric_limits<int>::max();
  const long long v = huge ? std::numeric_limits<long long>::max() : value->get<long long>();
  if (v < min_value || v > std::numeric_limits<int>::max()) {
    return fieldError(path + key, "out of range (" + std::to_string(v) + ")");
  }
  *out = static_cast<int>(v);
  return Status::Ok();
}

inline Status readNumber(const json& parent, const std::string& path, const char* key,
                         double* out) {
  const json* value = nullptr;
  Status status = member(parent, path, key, &value);
  if (!status) return status;
  if (!value->is_number()) return fieldError(path + key, "expected a number");
  const double v = value->get<double>();
  if (!std::isfinite(v)) return fieldError(path + key, "not finite");
  *out = v;
  return Status::Ok();
}

inline Status readVector3(const json& value, const std::string& path, Eigen::Vector3d* out) {
  if (!value.is_array() || value.size() != 3) return fieldError(path, "expected [x, y, z]");
  Eigen::Vector3d v;
  for (int i = 0; i < 3; ++i) {
    if (!value[i].is_number()) return fieldError(path, "expected numbers");
    v[i] = value[i].get<double>();
    if (!std::isfinite(v[i])) return fieldError(path, "not finite");
    // Every vector of a map is a position, size or direction in metres, within the map's reach
    // (map_limits.h): what the inputs were allowed to build.
    if (std::abs(v[i]) > kMapCoordinateLimitM) {
      std::ostringstream text;
      text << "beyond +-" << kMapCoordinateLimitM << " m (" << v[i] << ")";
      return fieldError(path, text.str());
    }
  }
  *out = v;
  return Status::Ok();
}

inline Status readVector3(const json& parent, const std::string& path, const char* key,
                          Eigen::Vector3d* out) {
  const json* value = nullptr;
  Status status = member(parent, path, key, &value);
  if (!status) return status;
  return readVector3(*value, path + key, out);
}

inline Status readCloud(const json& value, const std::string& path, PointCloud* out) {
  if (!value.is_array()) return fieldError(path, "expected an array of [x, y, z]");
  PointCloud cloud;
  cloud.reserve(value.size());
  for (size_t i = 0; i < value.size(); ++i) {
    Eigen::Vector3d p;
    const Status status = readVector3(value[i], path + "[" + std::to_string(i) + "]", &p);
    if (!status) return status;
    cloud.push_back(p.cast<float>());
  }
  *out = std::move(cloud);
  return Status::Ok();
}

}  // namespace json_fields
}  // namespace mvod
