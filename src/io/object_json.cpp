#include "object_json.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "json_fields.h"
#include "multiview_object_detection/pipeline/types/map_limits.h"
#include "multiview_object_detection/pipeline/utils/voxel_key.h"

namespace mvod {
namespace object_json {
namespace {

using nlohmann::json;

using namespace json_fields;  // NOLINT: the map's field readers

// A voxel's summed unit normals: bounded by the points that fell in it over all views.
constexpr double kMaxNormalSum = 1e7;

// id, class, probability and observations.
Status readIdentity(const json& value, const std::string& prefix, MapObject* object) {
  Status status;
  if (!(status = readInt(value, prefix, "id", 0, &object->id))) return status;
  if (object->id > kMaxObjectId) {
    return fieldError(prefix + "id", "beyond " + std::to_string(kMaxObjectId));
  }
  const json* name = nullptr;
  if (!(status = member(value, prefix, "class_name", &name))) return status;
  if (!name->is_string()) return fieldError(prefix + "class_name", "expected a string");
  object->class_name = name->get<std::string>();
  if (object->class_name.empty()) return fieldError(prefix + "class_name", "empty");
  if (!(status = readInt(value, prefix, "class_id", -1, &object->class_id))) return status;
  if (!(status = readNumber(value, prefix, "probability", &object->probability))) return status;
  if (object->probability < 0.0 || object->probability > 1.0) {
    return fieldError(prefix + "probability", "must be in [0, 1]");
  }
  return readInt(value, prefix, "observations", 0, &object->observations);
}

// A 3 x 3 array of rows that is a rotation.
Status readRotation(const json& value, const std::string& prefix, Eigen::Matrix3d* R) {
  const json* rotation = nullptr;
  Status status;
  if (!(status = member(value, prefix, "rotation", &rotation))) return status;
  if (!rotation->is_array() || rotation->size() != 3) {
    return fieldError(prefix + "rotation", "expected a 3x3 array of rows");
  }
  for (int r = 0; r < 3; ++r) {
    Eigen::Vector3d row;
    if (!(status =
              readVector3((*rotation)[r], prefix + "rotation[" + std::to_string(r) + "]", &row))) {
      return status;
    }
    R->row(r) = row.transpose();
  }
  if (!(R->transpose() * *R).isApprox(Eigen::Matrix3d::Identity(), 1e-3) ||
      std::abs(R->determinant() - 1.0) > 1e-3) {
    return fieldError(prefix + "rotation", "not a rotation (orthonormal, determinant +1)");
  }
  return Status::Ok();
}

// A box's centre, size (not negative) and rotation.
Status readBoxFields(const json& value, const std::string& prefix, OrientedBox* box) {
  Status status;
  if (!(status = readVector3(value, prefix, "center", &box->center_m))) return status;
  if (!(status = readVector3(value, prefix, "size", &box->size_m))) return status;
  if ((box->size_m.array() < 0.0).any()) return fieldError(prefix + "size", "negative");
  return readRotation(value, prefix, &box->rotation);
}

// The box (centre, size, rotation) and its yaw.
Status readBox(const json& value, const std::string& prefix, MapObject* object) {
  Status status;
  if (!(status = readBoxFields(value, prefix, &object->box))) return status;
  return readNumber(value, prefix, "yaw", &object->yaw_rad);
}

// The views' boxes (optional: a map saved before them boxes its objects by the union until new
// views come); the last kMaxViewBoxes of a longer list.
Status readViewBoxes(const json& value, const std::string& prefix, MapObject* object) {
  const auto list = value.find("view_boxes");
  if (list == value.end()) return Status::Ok();
  if (!list->is_array()) {
    return fieldError(prefix + "view_boxes",
                      "expected [{\"center\": [x, y, z], \"size\": [sx, sy, sz], "
                      "\"rotation\": [[...], [...], [...]]}, ...]");
  }
  const std::size_t first = list->size() > kMaxViewBoxes ? list->size() - kMaxViewBoxes : 0;
  for (std::size_t i = first; i < list->size(); ++i) {
    const std::string where = prefix + "view_boxes[" + std::to_string(i) + "]";
    if (!(*list)[i].is_object()) return fieldError(where, "expected an object");
    OrientedBox box;
    const Status status = readBoxFields((*list)[i], where + ".", &box);
    if (!status) return status;
    object->view_boxes.push_back(box);
  }
  return Status::Ok();
}

// First and last keyframe and stamp.
Status readSeen(const json& value, const std::string& prefix, MapObject* object) {
  Status status;
  if (!(status = readInt(value, prefix, "first_keyframe", std::numeric_limits<int>::min(),
                         &object->first_keyframe))) {
    return status;
  }
  if (!(status = readInt(value, prefix, "last_keyframe", std::numeric_limits<int>::min(),
                         &object->last_keyframe))) {
    return status;
  }
  if (!(status = readNumber(value, prefix, "first_seen", &object->first_seen_s))) return status;
  return readNumber(value, prefix, "last_seen", &object->last_seen_s);
}

// Clouds are optional (include_clouds); when present, num_points must match.
Status readClouds(const json& value, const std::string& prefix, MapObject* object) {
  int num_points = 0;
  Status status;
  if (!(status = readInt(value, prefix, "num_points", 0, &num_points))) return status;
  const auto points = value.find("points");
  if (points != value.end()) {
    if (!(status = readCloud(*points, prefix + "points", &object->points_W))) return status;
    if (static_cast<int>(object->points_W.size()) != num_points) {
      return fieldError(prefix + "num_points", "does not match the number of points");
    }
  }
  const auto segment = value.find("segment");
  if (segment != value.end()) {
    if (!(status = readCloud(*segment, prefix + "segment", &object->segment_W))) return status;
  }
  return Status::Ok();
}

// Evidence fusion's class votes (optional).
Status readClassScores(const json& value, const std::string& prefix, MapObject* object) {
  const auto scores = value.find("class_scores");
  if (scores == value.end()) return Status::Ok();
  if (!scores->is_object()) {
    return fieldError(prefix + "class_scores", "expected {\"class\": summed probability, ...}");
  }
  for (auto it = scores->begin(); it != scores->end(); ++it) {
    if (!it.value().is_number() || !std::isfinite(it.value().get<double>()) ||
        it.value().get<double>() < 0.0) {
      return fieldError(prefix + "class_scores", "values must be finite numbers >= 0");
    }
    object->class_scores[it.key()] = it.value().get<double>();
  }
  return Status::Ok();
}

// An integer of a voxel or cell entry: not an unsigned value beyond INT64_MAX (it would wrap to a
// negative number), and in [min_value, max_value].
bool integerInRange(const json& value, std::int64_t min_value, std::int64_t max_value) {
  if (!value.is_number_integer()) return false;
  if (value.is_number_unsigned() &&
      value.get<std::uint64_t>() >
          static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) {
    return false;
  }
  const std::int64_t v = value.get<std::int64_t>();
  return v >= min_value && v <= max_value;
}

// [i, j, k, a, b]'s grid index within the key's range (voxel_key.h).
bool gridIndex(const json& entry, Eigen::Vector3i* index) {
  for (int i = 0; i < 3; ++i) {
    if (!integerInRange(entry[i], -(1 << 20), (1 << 20) - 1)) return false;
    (*index)[i] = entry[i].get<int>();
  }
  return true;
}

// One evidence voxel: [i, j, k, in, out], with the voxel's summed normal [..., nx, ny, nz], and
// with its summed signed distance and their count [..., nx, ny, nz, sdf_sum, sdf_count].
bool readEvidenceVoxel(const json& voxel, std::int64_t* key, VoxelEvidence* e) {
  if (!voxel.is_array() || !(voxel.size() == 5 || voxel.size() == 8 || voxel.size() == 10)) {
    return false;
  }
  Eigen::Vector3i index;
  if (!gridIndex(voxel, &index) || !integerInRange(voxel[3], 0, UINT16_MAX) ||
      !integerInRange(voxel[4], 0, UINT16_MAX)) {
    return false;
  }
  // A sum of unit normals: no larger than the number of points that can fall in a voxel.
  const auto bounded = [](const json& v) {
    return v.is_number() && std::isfinite(v.get<double>()) &&
           std::abs(v.get<double>()) <= kMaxNormalSum;
  };
  e->normal_sum = Eigen::Vector3f::Zero();
  for (size_t i = 5; i < voxel.size() && i < 8; ++i) {
    if (!bounded(voxel[i])) return false;
    e->normal_sum[static_cast<int>(i) - 5] = voxel[i].get<float>();
  }
  e->sdf_sum = 0.f;
  e->sdf_count = 0;
  if (voxel.size() == 10) {
    // A count of views, and their signed distances, each truncated to a few decimetres.
    if (voxel[9].is_number_float() || !integerInRange(voxel[9], 0, UINT16_MAX) ||
        !bounded(voxel[8])) {
      return false;
    }
    e->sdf_sum = voxel[8].get<float>();
    e->sdf_count = static_cast<std::uint16_t>(voxel[9].get<std::int64_t>());
  }
  e->inside = static_cast<std::uint16_t>(voxel[3].get<int>());
  e->outside = static_cast<std::uint16_t>(voxel[4].get<int>());
  *key = packVoxel(index);
  return true;
}

// Evidence fusion's votes (optional; maps without them go on fusing from their segment).
Status readEvidence(const json& value, const std::string& prefix, MapObject* object) {
  const auto evidence = value.find("evidence");
  if (evidence == value.end()) return Status::Ok();
  const std::string where = prefix + "evidence";
  if (!evidence->is_object() || !evidence->contains("voxel_size_m") ||
      !(*evidence)["voxel_size_m"].is_number() || !evidence->contains("voxels") ||
      !(*evidence)["voxels"].is_array()) {
    return fieldError(where,
                      "expected {\"voxel_size_m\": s, \"voxels\": [[i, j, k, in, out], ...]}");
  }
  const double size_m = (*evidence)["voxel_size_m"].get<double>();
  if (!(std::isfinite(size_m) && size_m > 0.0))
    return fieldError(where, "voxel_size_m must be > 0");
  // No voxels = no grid yet (0), as objectsToJson writes no "evidence" then: the map round-trips.
  object->evidence_voxel_size_m = (*evidence)["voxels"].empty() ? 0.0 : size_m;
  for (const json& voxel : (*evidence)["voxels"]) {
    std::int64_t key = 0;
    VoxelEvidence e;
    if (!readEvidenceVoxel(voxel, &key, &e)) {
      return fieldError(where,
                        "voxels must be [i, j, k, in, out], [i, j, k, in, out, nx, ny, nz] or "
                        "[i, j, k, in, out, nx, ny, nz, sdf_sum, sdf_count] with integers in "
                        "range and finite numbers");
    }
    object->evidence[key] = e;
  }
  return Status::Ok();
}

// Amodal completion's free space around the object (optional; maps without it count afresh).
Status readFreeSpace(const json& value, const std::string& prefix, MapObject* object) {
  const auto free_space = value.find("free_space");
  if (free_space == value.end()) return Status::Ok();
  const std::string where = prefix + "free_space";
  const char* expected =
      "expected {\"cell_size_m\": s, \"cells\": [[i, j, k, in_view, seen_free], ...]} with "
      "integers in range and seen_free <= in_view";
  if (!free_space->is_object() || !free_space->contains("cell_size_m") ||
      !(*free_space)["cell_size_m"].is_number() || !free_space->contains("cells") ||
      !(*free_space)["cells"].is_array()) {
    return fieldError(where, expected);
  }
  const double size_m = (*free_space)["cell_size_m"].get<double>();
  if (!(std::isfinite(size_m) && size_m > 0.0)) {
    return fieldError(where, "cell_size_m must be > 0");
  }
  object->free_space_cell_m = (*free_space)["cells"].empty() ? 0.0 : size_m;
  for (const json& cell : (*free_space)["cells"]) {
    Eigen::Vector3i index;
    const bool ok = cell.is_array() && cell.size() == 5 && gridIndex(cell, &index) &&
                    integerInRange(cell[3], 0, UINT16_MAX) &&
                    integerInRange(cell[4], 0, UINT16_MAX) &&
                    cell[4].get<std::int64_t>() <= cell[3].get<std::int64_t>();
    if (!ok) return fieldError(where, expected);
    FreeSpaceCount& count = object->free_space[packVoxel(index)];
    count.in_view = static_cast<std::uint16_t>(cell[3].get<int>());
    count.seen_free = static_cast<std::uint16_t>(cell[4].get<int>());
  }
  return Status::Ok();
}

// Whether the box was completed, and the observed part (same rotation); without it, the box.
Status readCompletion(const json& value, const std::string& prefix, MapObject* object) {
  const auto completed = value.find("box_completed");
  if (completed != value.end()) {
    if (!completed->is_boolean()) {
      return fieldError(prefix + "box_completed", "expected true or false");
    }
    object->box_completed = completed->get<bool>();
  }
  object->observed_box = object->box;
  const auto observed = value.find("observed_box");
  if (observed == value.end()) return Status::Ok();
  const std::string where = prefix + "observed_box";
  if (!observed->is_object()) {
    return fieldError(where, "expected {\"center\": [x, y, z], \"size\": [sx, sy, sz]} (m)");
  }
  Eigen::Vector3d center;
  Eigen::Vector3d size;
  Status status;
  if (!(status = readVector3(*observed, where + ".", "center", &center))) return status;
  if (!(status = readVector3(*observed, where + ".", "size", &size))) return status;
  if ((size.array() < 0.0).any()) return fieldError(where + ".size", "negative");
  object->observed_box.center_m = center;
  object->observed_box.size_m = size;
  return Status::Ok();
}

// Existence evidence (optional: a map saved before it starts every object afresh).
Status readExistence(const json& value, const std::string& prefix, MapObject* object) {
  const auto existence = value.find("existence");
  if (existence == value.end()) return Status::Ok();
  const std::string where = prefix + "existence.";
  if (!existence->is_object()) return fieldError(prefix + "existence", "expected an object");
  ExistenceEvidence& e = object->existence;
  Status status;
  if (!(status = readNumber(*existence, where, "log_odds", &e.log_odds))) return status;
  if (std::abs(e.log_odds) > 100.0) return fieldError(where + "log_odds", "beyond +-100");
  int counts[3] = {0, 0, 0};
  const char* names[3] = {"detected", "missed", "seen_through"};
  for (int i = 0; i < 3; ++i) {
    if (!(status = readInt(*existence, where, names[i], 0, &counts[i]))) return status;
  }
  e.detected = static_cast<std::uint32_t>(counts[0]);
  e.missed = static_cast<std::uint32_t>(counts[1]);
  e.seen_through = static_cast<std::uint32_t>(counts[2]);
  return Status::Ok();
}

// The evidence grid, its voxels sorted so that one map always writes the same file.
json evidenceToJson(const MapObject& object) {
  std::vector<std::pair<Eigen::Vector3i, VoxelEvidence>> voxels;
  for (const auto& e : object.evidence) {
    voxels.emplace_back(unpackVoxel(e.first), e.second);
  }
  std::sort(voxels.begin(), voxels.end(), [](const auto& a, const auto& b) {
    return std::lexicographical_compare(a.first.data(), a.first.data() + 3, b.first.data(),
                                        b.first.data() + 3);
  });
  json list_json = json::array();
  for (const auto& v : voxels) {
    json voxel = {v.first.x(), v.first.y(), v.first.z(), v.second.inside, v.second.outside};
    const Eigen::Vector3f& n = v.second.normal_sum;
    if (!n.isZero() || v.second.sdf_count > 0) {
      for (int i = 0; i < 3; ++i) voxel.push_back(n[i]);
    }
    if (v.second.sdf_count > 0) {
      voxel.push_back(v.second.sdf_sum);
      voxel.push_back(v.second.sdf_count);
    }
    list_json.push_back(std::move(voxel));
  }
  return {{"voxel_size_m", object.evidence_voxel_size_m}, {"voxels", std::move(list_json)}};
}

// A rotation as a 3 x 3 array of rows.
json rotationToJson(const Eigen::Matrix3d& R) {
  json rows = json::array();
  for (int r = 0; r < 3; ++r) rows.push_back(json::array({R(r, 0), R(r, 1), R(r, 2)}));
  return rows;
}

// The free-space cells, sorted.
json freeSpaceToJson(const MapObject& object) {
  std::vector<std::pair<Eigen::Vector3i, FreeSpaceCount>> cells;
  for (const auto& c : object.free_space) cells.emplace_back(unpackVoxel(c.first), c.second);
  std::sort(cells.begin(), cells.end(), [](const auto& a, const auto& b) {
    return std::lexicographical_compare(a.first.data(), a.first.data() + 3, b.first.data(),
                                        b.first.data() + 3);
  });
  json cells_json = json::array();
  for (const auto& c : cells) {
    cells_json.push_back(
        {c.first.x(), c.first.y(), c.first.z(), c.second.in_view, c.second.seen_free});
  }
  return {{"cell_size_m", object.free_space_cell_m}, {"cells", std::move(cells_json)}};
}

}  // namespace

json objectToJson(const MapObject& object, bool include_clouds) {
  json entry = {{"id", object.id},
                {"class_name", object.class_name},
                {"class_id", object.class_id},
                {"probability", object.probability},
                {"observations", object.observations},
                {"center", vectorToJson(object.box.center_m)},
                {"size", vectorToJson(object.box.size_m)},
                {"rotation", rotationToJson(object.box.rotation)},
                {"yaw", object.yaw_rad},
                {"num_points", object.points_W.size()},
                {"first_keyframe", object.first_keyframe},
                {"last_keyframe", object.last_keyframe},
                {"first_seen", object.first_seen_s},
                {"last_seen", object.last_seen_s},
                {"box_completed", object.box_completed},
                {"existence",
                 {{"log_odds", object.existence.log_odds},
                  {"probability", object.existence.probability()},
                  {"detected", object.existence.detected},
                  {"missed", object.existence.missed},
                  {"seen_through", object.existence.seen_through}}}};
  if (object.box_completed) {
    entry["observed_box"] = {{"center", vectorToJson(object.observed_box.center_m)},
                             {"size", vectorToJson(object.observed_box.size_m)}};
  }
  if (!object.class_scores.empty()) {
    json scores = json::object();
    for (const auto& score : object.class_scores) scores[score.first] = score.second;
    entry["class_scores"] = std::move(scores);
  }
  if (include_clouds) {
    entry["points"] = cloudToJson(object.points_W);
    entry["segment"] = cloudToJson(object.segment_W);
    if (!object.evidence.empty()) entry["evidence"] = evidenceToJson(object);
    if (!object.free_space.empty()) entry["free_space"] = freeSpaceToJson(object);
    if (!object.view_boxes.empty()) {
      json view_boxes = json::array();
      for (const OrientedBox& box : object.view_boxes) {
        view_boxes.push_back({{"center", vectorToJson(box.center_m)},
                              {"size", vectorToJson(box.size_m)},
                              {"rotation", rotationToJson(box.rotation)}});
      }
      entry["view_boxes"] = std::move(view_boxes);
    }
  }
  return entry;
}

Status objectFromJson(const json& value, const std::string& path, MapObject* out) {
  if (!value.is_object()) return fieldError(path, "expected an object");
  const std::string prefix = path + ".";
  MapObject object;
  for (const auto read :
       {readIdentity, readBox, readSeen, readClouds, readClassScores, readEvidence, readFreeSpace,
        readCompletion, readExistence, readViewBoxes}) {
    const Status status = read(value, prefix, &object);
    if (!status) return status;
  }
  *out = std::move(object);
  return Status::Ok();
}

}  // namespace object_json
}  // namespace mvod
