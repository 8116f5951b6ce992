// The synthetic ground_truth.json of SyntheticScene::writeSevenScenes (also the hand-annotated
// redkitchen boxes in test/data): {"objects": [{"class_name", "center", "size", "rotation" (rows)
// or "yaw", optional "points"}, ...]}.
#include <cmath>
#include <nlohmann/json.hpp>

#include "multiview_object_detection/datasets/class_names.h"
#include "multiview_object_detection/datasets/ground_truth.h"
#include "multiview_object_detection/datasets/ground_truth_geometry.h"
#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/pipeline/stages/manhattan_frame.h"

namespace mvod {
namespace {

bool readVector(const nlohmann::json& value, Eigen::Vector3d* out) {
  if (!value.is_array() || value.size() != 3) return false;
  for (int i = 0; i < 3; ++i) {
    if (!value[i].is_number()) return false;
    (*out)[i] = value[i].get<double>();
  }
  return out->allFinite();
}

// "rotation" (3x3 rows) or else "yaw" about up_W.
Status readRotation(const nlohmann::json& entry, const std::string& where,
                    const Eigen::Vector3d& up_W, Eigen::Matrix3d* rotation) {
  if (entry.contains("rotation")) {
    const nlohmann::json& rows = entry["rotation"];
    if (!rows.is_array() || rows.size() != 3) {
      return Status::Error(where + ".rotation: expected a 3x3 array of rows");
    }
    for (int r = 0; r < 3; ++r) {
      Eigen::Vector3d row;
      if (!readVector(rows[r], &row)) {
        return Status::Error(where + ".rotation: expected a 3x3 array of rows");
      }
      rotation->row(r) = row.transpose();
    }
    const Eigen::Matrix3d& R = *rotation;
    if (!(R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), 1e-3) ||
        std::abs(R.determinant() - 1.0) > 1e-3) {
      return Status::Error(where + ".rotation: not a rotation");
    }
    return Status::Ok();
  }
  if (entry.contains("yaw") && entry["yaw"].is_number()) {
    *rotation = GravityFrame(-up_W).rotationFromYaw(entry["yaw"].get<double>());
    return Status::Ok();
  }
  return Status::Error(where + ": needs rotation or yaw");
}

// Optional observed ground-truth surface (e.g. noise-free depth of the object's pixels).
Status readPoints(const nlohmann::json& entry, const std::string& where, PointCloud* points) {
  if (!entry.contains("points")) return Status::Ok();
  const nlohmann::json& list = entry["points"];
  if (!list.is_array()) return Status::Error(where + ".points: expected [[x, y, z], ...]");
  for (size_t k = 0; k < list.size(); ++k) {
    Eigen::Vector3d p;
    if (!readVector(list[k], &p)) {
      return Status::Error(where + ".points[" + std::to_string(k) + "]: expected [x, y, z]");
    }
    points->push_back(p.cast<float>());
  }
  return Status::Ok();
}

// One entry of "objects"; *skip for unlabelled clutter (empty class), which is scenery.
Status readObject(const nlohmann::json& entry, const std::string& where, double spacing_m,
                  const Eigen::Vector3d& up_W, GroundTruthObject* object, bool* skip) {
  if (!entry.is_object()) return Status::Error(where + ": expected an object");
  if (!entry.contains("class_name") || !entry["class_name"].is_string()) {
    return Status::Error(where + ".class_name: missing or not a string");
  }
  object->class_name = canonicalClassName(entry["class_name"].get<std::string>());
  if (!entry.contains("center") || !readVector(entry["center"], &object->box.center_m)) {
    return Status::Error(where + ".center: expected [x, y, z]");
  }
  if (!entry.contains("size") || !readVector(entry["size"], &object->box.size_m) ||
      (object->box.size_m.array() < 0.0).any()) {
    return Status::Error(where + ".size: expected [x, y, z] >= 0");
  }
  const Status rotation = readRotation(entry, where, up_W, &object->box.rotation);
  if (!rotation) return rotation;
  *skip = object->class_name.empty();
  if (*skip) return Status::Ok();
  const Status points = readPoints(entry, where, &object->points_W);
  if (!points) return points;
  if (object->points_W.empty()) object->points_W = sampleBoxSurface(object->box, spacing_m, up_W);
  return Status::Ok();
}

}  // namespace

Status readGroundTruthUp(const std::string& path, Eigen::Vector3d* up_W, bool* found) {
  *found = false;
  std::string text;
  const Status status = readFile(path, &text);
  if (!status) return status;
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    return Status::Error(path + ": not valid JSON: " + e.what());
  }
  if (!doc.is_object() || !doc.contains("up")) return Status::Ok();
  Eigen::Vector3d up;
  if (!readVector(doc["up"], &up) || !(up.norm() > 0.0)) {
    return Status::Error(path + ".up: expected a non-zero [x, y, z]");
  }
  *up_W = up.normalized();
  *found = true;
  return Status::Ok();
}

Status loadSyntheticGroundTruth(const std::string& path, double spacing_m,
                                const Eigen::Vector3d& up_W,
                                std::vector<GroundTruthObject>* objects) {
  if (objects == nullptr) return Status::Error(path + ": no output");
  std::string text;
  Status status = readFile(path, &text);
  if (!status) return status;
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    return Status::Error(path + ": not valid JSON: " + e.what());
  }
  if (!doc.is_object() || !doc.contains("objects") || !doc["objects"].is_array()) {
    return Status::Error(path + ": expected {\"objects\": [...]}");
  }
  std::vector<GroundTruthObject> parsed;
  const nlohmann::json& list = doc["objects"];
  for (size_t i = 0; i < list.size(); ++i) {
    GroundTruthObject object;
    bool skip = false;
    status = readObject(list[i], path + ": objects[" + std::to_string(i) + "]", spacing_m, up_W,
                        &object, &skip);
    if (!status) return status;
    if (!skip) parsed.push_back(std::move(object));
  }
  *objects = std::move(parsed);
  return Status::Ok();
}

}  // namespace mvod
