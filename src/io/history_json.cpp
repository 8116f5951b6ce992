#include "history_json.h"

#include <boost/archive/iterators/base64_from_binary.hpp>
#include <boost/archive/iterators/binary_from_base64.hpp>
#include <boost/archive/iterators/transform_width.hpp>
#include <cstdint>
#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <vector>

#include "json_fields.h"
#include "multiview_object_detection/io/image_io.h"

namespace mvod {
namespace history_json {
namespace {

using json_fields::fieldError;
using json_fields::json;

// Larger depth images than any depth camera gives are refused before decoding.
constexpr int64_t kMaxDepthPixels = int64_t{4096} * 4096;

std::string toBase64(const void* data, std::size_t bytes) {
  using Encoder = boost::archive::iterators::base64_from_binary<
      boost::archive::iterators::transform_width<const char*, 6, 8>>;
  const char* begin = static_cast<const char*>(data);
  std::string text(Encoder(begin), Encoder(begin + bytes));
  text.append((3 - bytes % 3) % 3, '=');
  return text;
}

bool fromBase64(const std::string& text, std::vector<std::uint8_t>* bytes) {
  using Decoder = boost::archive::iterators::transform_width<
      boost::archive::iterators::binary_from_base64<std::string::const_iterator>, 8, 6>;
  if (text.size() % 4 != 0) return false;
  std::size_t padding = 0;
  while (padding < 2 && padding < text.size() && text[text.size() - 1 - padding] == '=') {
    ++padding;
  }
  for (std::size_t i = 0; i + padding < text.size(); ++i) {
    const char c = text[i];
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '+' || c == '/')) return false;
  }
  std::string body = text.substr(0, text.size() - padding);
  body.append(padding, 'A');  // decodes to zero bits, dropped below
  try {
    bytes->assign(Decoder(body.begin()), Decoder(body.end()));
  } catch (const std::exception&) {
    return false;
  }
  bytes->resize(bytes->size() - padding);
  return true;
}

// An array's bytes: a base64 string (blobs null), or appended to *blobs as [offset, size].
json putBytes(const void* data, std::size_t bytes, std::string* blobs) {
  if (blobs == nullptr) return toBase64(data, bytes);
  const std::size_t offset = blobs->size();
  blobs->append(static_cast<const char*>(data), bytes);
  return json::array({offset, bytes});
}

template <typename T>
json putArray(const std::vector<T>& values, std::string* blobs) {
  return putBytes(values.data(), values.size() * sizeof(T), blobs);
}

json isometryToJson(const Eigen::Isometry3d& T) {
  json rows = json::array();
  for (int r = 0; r < 3; ++r) {
    rows.push_back(json::array({T(r, 0), T(r, 1), T(r, 2), T(r, 3)}));
  }
  return rows;
}

json depthToJson(const cv::Mat& depth, std::string* blobs) {
  if (depth.empty()) return nullptr;
  json out{{"width", depth.cols}, {"height", depth.rows}};
  if (depth.type() == CV_16UC1) {
    std::vector<std::uint8_t> png;
    cv::imencode(".png", depth, png, {cv::IMWRITE_PNG_COMPRESSION, 1});
    out["encoding"] = "png16";
    out["data"] = putArray(png, blobs);
  } else {
    const cv::Mat continuous = depth.isContinuous() ? depth : depth.clone();
    out["encoding"] = "float32";
    out["data"] = putBytes(continuous.data, continuous.total() * sizeof(float), blobs);
  }
  return out;
}

json viewToJson(const RecordedView& view, std::string* blobs) {
  const RecordedCut& recorded = *view.cut;
  std::vector<float> cut;
  cut.reserve(recorded.cut_W.size() * 3);
  for (const Eigen::Vector3f& p : recorded.cut_W) cut.insert(cut.end(), {p.x(), p.y(), p.z()});
  std::vector<float> normals;
  normals.reserve(recorded.normals_W.size() * 3);
  for (const Eigen::Vector3f& n : recorded.normals_W) {
    normals.insert(normals.end(), {n.x(), n.y(), n.z()});
  }
  json rotation = json::array();
  for (int r = 0; r < 3; ++r) {
    rotation.push_back(
        json::array({view.box.rotation(r, 0), view.box.rotation(r, 1), view.box.rotation(r, 2)}));
  }
  return json{{"class_id", view.class_id},
              {"class_name", view.class_name},
              {"probability", view.probability},
              {"object_id", view.object_id},
              {"center", json_fields::vectorToJson(view.box.center_m)},
              {"size", json_fields::vectorToJson(view.box.size_m)},
              {"rotation", rotation},
              {"yaw", view.yaw_rad},
              {"voxel_size_m", recorded.voxel_size_m},
              {"cut", putArray(cut, blobs)},
              {"normals", putArray(normals, blobs)},
              {"outside", putArray(recorded.outside_keys, blobs)}};
}

// ---------------------------------------------------------------------------------------------
// Reading

Status readString(const json& parent, const std::string& path, const char* key, std::string* out) {
  const json* value = nullptr;
  Status status = json_fields::member(parent, path, key, &value);
  if (!status) return status;
  if (!value->is_string()) return fieldError(path + key, "expected a string");
  *out = value->get<std::string>();
  return Status::Ok();
}

// An array's bytes: a base64 string, or [offset, size] into `blobs`.
Status readBytes(const json& parent, const std::string& path, const char* key,
                 std::size_t element_bytes, const std::string* blobs,
                 std::vector<std::uint8_t>* bytes) {
  const json* value = nullptr;
  Status status = json_fields::member(parent, path, key, &value);
  if (!status) return status;
  const std::string what = "expected " + std::string(blobs != nullptr ? "[offset, size] or " : "") +
                           "base64 of " + std::to_string(element_bytes) + "-byte elements";
  if (value->is_string()) {
    if (!fromBase64(value->get_ref<const std::string&>(), bytes)) {
      return fieldError(path + key, what);
    }
  } else if (blobs != nullptr && value->is_array() && value->size() == 2 &&
             (*value)[0].is_number_unsigned() && (*value)[1].is_number_unsigned()) {
    const std::uint64_t offset = (*value)[0].get<std::uint64_t>();
    const std::uint64_t size = (*value)[1].get<std::uint64_t>();
    if (offset > blobs->size() || size > blobs->size() - offset) {
      return fieldError(path + key, "[offset, size] beyond the file's data");
    }
    bytes->assign(blobs->begin() + static_cast<std::ptrdiff_t>(offset),
                  blobs->begin() + static_cast<std::ptrdiff_t>(offset + size));
  } else {
    return fieldError(path + key, what);
  }
  if (bytes->size() % element_bytes != 0) return fieldError(path + key, what);
  return Status::Ok();
}

// Triples of float32: points (finite, within the map's range) or normals (unit or NaN).
Status readTriples(const json& parent, const std::string& path, const char* key, bool normals,
                   const std::string* blobs, std::vector<Eigen::Vector3f>* out) {
  std::vector<std::uint8_t> bytes;
  Status status = readBytes(parent, path, key, 3 * sizeof(float), blobs, &bytes);
  if (!status) return status;
  out->resize(bytes.size() / (3 * sizeof(float)));
  std::memcpy(static_cast<void*>(out->data()), bytes.data(), bytes.size());  // packed floats
  for (const Eigen::Vector3f& v : *out) {
    const bool ok = normals ? (!v.allFinite() ? v.hasNaN() : v.norm() <= 1.01f)
                            : v.allFinite() && v.cwiseAbs().maxCoeff() <= kMapCoordinateLimitM;
    if (!ok) {
      return fieldError(path + key, normals ? "normals must be unit vectors (or NaN)"
                                            : "points must be finite, within the map's range");
    }
  }
  return Status::Ok();
}

Status readDepth(const json& value, const std::string& path, const std::string* blobs,
                 cv::Mat* depth) {
  if (value.is_null()) return Status::Ok();  // given up (max_keyframes_with_depth)
  int width = 0;
  int height = 0;
  std::string encoding;
  Status status;
  if (!value.is_object()) return fieldError(path, "expected an object or null");
  if (!(status = json_fields::readInt(value, path + ".", "width", 1, &width)) ||
      !(status = json_fields::readInt(value, path + ".", "height", 1, &height)) ||
      !(status = readString(value, path + ".", "encoding", &encoding))) {
    return status;
  }
  if (int64_t{width} * height > kMaxDepthPixels) return fieldError(path, "too large");
  std::vector<std::uint8_t> bytes;
  if (encoding == "png16") {
    if (!(status = readBytes(value, path + ".", "data", 1, blobs, &bytes))) return status;
    cv::Mat decoded;
    status = decodeImageChecked(bytes, path, cv::IMREAD_UNCHANGED, cv::Size(width, height),
                                kMaxDepthPixels, &decoded);
    if (!status) return status;
    if (decoded.type() != CV_16UC1) return fieldError(path, "not a 16-bit one-channel PNG");
    *depth = decoded;
    return Status::Ok();
  }
  if (encoding != "float32") return fieldError(path + ".encoding", "png16 or float32");
  if (!(status = readBytes(value, path + ".", "data", sizeof(float), blobs, &bytes))) {
    return status;
  }
  if (bytes.size() != static_cast<std::size_t>(width) * height * sizeof(float)) {
    return fieldError(path + ".data", "does not hold width x height floats");
  }
  cv::Mat decoded(height, width, CV_32FC1);
  std::memcpy(decoded.data, bytes.data(), bytes.size());
  *depth = decoded;
  return Status::Ok();
}

Status readView(const json& value, const std::string& path, const std::string* blobs,
                RecordedView* view) {
  if (!value.is_object()) return fieldError(path, "expected an object");
  auto cut = std::make_shared<RecordedCut>();
  const std::string p = path + ".";
  Status status;
  if (!(status = json_fields::readInt(value, p, "class_id", -1, &view->class_id)) ||
      !(status = readString(value, p, "class_name", &view->class_name)) ||
      !(status = json_fields::readNumber(value, p, "probability", &view->probability)) ||
      !(status = json_fields::readInt(value, p, "object_id", -1, &view->object_id)) ||
      !(status = json_fields::readVector3(value, p, "center", &view->box.center_m)) ||
      !(status = json_fields::readVector3(value, p, "size", &view->box.size_m)) ||
      !(status = json_fields::readNumber(value, p, "yaw", &view->yaw_rad)) ||
      !(status = json_fields::readNumber(value, p, "voxel_size_m", &cut->voxel_size_m))) {
    return status;
  }
  if (view->class_name.empty()) return fieldError(p + "class_name", "empty");
  if (!(view->probability >= 0.0 && view->probability <= 1.0)) {
    return fieldError(p + "probability", "must be in [0, 1]");
  }
  if (!(cut->voxel_size_m > 1e-4 && cut->voxel_size_m <= 1.0)) {
    return fieldError(p + "voxel_size_m", "must be in (0.0001, 1] m");
  }
  const json* rotation = nullptr;
  if (!(status = json_fields::member(value, p, "rotation", &rotation))) return status;
  Eigen::Isometry3d R = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3 && rotation->is_array() && rotation->size() == 3; ++r) {
    Eigen::Vector3d row;
    if (!json_fields::readVector3((*rotation)[r], p + "rotation", &row)) break;
    R.linear().row(r) = row.transpose();
  }
  if (!isValidPose(R, 1e-3)) return fieldError(p + "rotation", "not a rotation");
  view->box.rotation = R.linear();
  if (!(status = readTriples(value, p, "cut", false, blobs, &cut->cut_W)) ||
      !(status = readTriples(value, p, "normals", true, blobs, &cut->normals_W))) {
    return status;
  }
  if (!cut->normals_W.empty() && cut->normals_W.size() != cut->cut_W.size()) {
    return fieldError(p + "normals", "one per cut point, or none");
  }
  std::vector<std::uint8_t> bytes;
  if (!(status = readBytes(value, p, "outside", sizeof(std::int64_t), blobs, &bytes))) {
    return status;
  }
  std::vector<std::int64_t>& keys = cut->outside_keys;
  keys.resize(bytes.size() / sizeof(std::int64_t));
  std::memcpy(keys.data(), bytes.data(), bytes.size());
  // Packed keys are non-negative (voxel_key.h); the replay takes them sorted, each once.
  for (const std::int64_t key : keys) {
    if (key < 0) return fieldError(p + "outside", "voxel keys must be >= 0");
  }
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  view->cut = std::move(cut);
  return Status::Ok();
}

}  // namespace

Status readPose(const json& parent, const std::string& path, const char* key,
                Eigen::Isometry3d* T) {
  const json* value = nullptr;
  Status status = json_fields::member(parent, path, key, &value);
  if (!status) return status;
  const std::string where = path + key;
  if (!value->is_array() || value->size() != 3) return fieldError(where, "expected 3 rows of 4");
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    const json& row = (*value)[r];
    if (!row.is_array() || row.size() != 4) return fieldError(where, "expected 3 rows of 4");
    for (int c = 0; c < 4; ++c) {
      if (!row[c].is_number()) return fieldError(where, "expected numbers");
      pose(r, c) = row[c].get<double>();
    }
  }
  if (!isValidPose(pose, 1e-3) || pose.translation().cwiseAbs().maxCoeff() > kMapCoordinateLimitM) {
    return fieldError(where, "not a rigid transform within the map's range");
  }
  *T = pose;
  return Status::Ok();
}

Status recordFromJson(const json& value, const std::string& path, const std::string* blobs,
                      KeyframeRecord* record) {
  if (!value.is_object()) return fieldError(path, "expected an object");
  const std::string p = path + ".";
  Status status;
  if (!(status = json_fields::readInt(value, p, "keyframe", 0, &record->keyframe)) ||
      !(status = json_fields::readNumber(value, p, "stamp", &record->stamp_s)) ||
      !(status = readString(value, p, "name", &record->name)) ||
      !(status = readPose(value, p, "T_W_D_recorded", &record->T_W_D_recorded)) ||
      !(status = readPose(value, p, "T_W_D", &record->T_W_D)) ||
      !(status = readPose(value, p, "T_C_D", &record->T_C_D))) {
    return status;
  }
  const json* K = nullptr;
  if (!(status = json_fields::member(value, p, "K", &K))) return status;
  if (!K->is_array() || K->size() != 6)
    return fieldError(p + "K", "expected [fx, fy, cx, cy, w, h]");
  for (std::size_t i = 0; i < 6; ++i) {
    if (!(*K)[i].is_number() || !std::isfinite((*K)[i].get<double>())) {
      return fieldError(p + "K", "expected finite numbers");
    }
  }
  record->K_depth = CameraIntrinsics{(*K)[0].get<double>(),
                                     (*K)[1].get<double>(),
                                     (*K)[2].get<double>(),
                                     (*K)[3].get<double>(),
                                     static_cast<int>(std::clamp((*K)[4].get<double>(), 0.0, 1e5)),
                                     static_cast<int>(std::clamp((*K)[5].get<double>(), 0.0, 1e5))};
  if (!record->K_depth.isValid()) return fieldError(p + "K", "fx and fy must be > 0");
  const auto floor = value.find("floor_point");
  if (floor != value.end()) {
    if (!(status = json_fields::readVector3(*floor, p + "floor_point", &record->floor_point_D))) {
      return status;
    }
    record->has_floor = true;
  }
  const auto refined = value.find("refined_after");
  if (refined != value.end()) {
    if (!refined->is_boolean()) return fieldError(p + "refined_after", "expected true or false");
    record->refined_after = refined->get<bool>();
  }
  const json* depth = nullptr;
  if (!(status = json_fields::member(value, p, "depth", &depth))) return status;
  if (!(status = readDepth(*depth, p + "depth", blobs, &record->depth))) return status;
  const auto coarse = value.find("depth_coarse");  // maps of 0.9.x and before have none
  if (coarse != value.end()) {
    if (!coarse->is_boolean()) return fieldError(p + "depth_coarse", "expected true or false");
    record->depth_coarse = coarse->get<bool>() && !record->depth.empty();
  }
  const json* views = nullptr;
  if (!(status = json_fields::member(value, p, "views", &views))) return status;
  if (!views->is_array()) return fieldError(p + "views", "expected an array");
  for (std::size_t i = 0; i < views->size(); ++i) {
    RecordedView view;
    if (!(status = readView((*views)[i], p + "views[" + std::to_string(i) + "]", blobs, &view))) {
      return status;
    }
    record->views.push_back(std::move(view));
  }
  return Status::Ok();
}

json recordToJson(const KeyframeRecord& record, std::string* blobs) {
  json views = json::array();
  for (const RecordedView& view : record.views) views.push_back(viewToJson(view, blobs));
  json entry{{"keyframe", record.keyframe},
             {"stamp", record.stamp_s},
             {"name", record.name},
             {"T_W_D_recorded", isometryToJson(record.T_W_D_recorded)},
             {"T_W_D", isometryToJson(record.T_W_D)},
             {"T_C_D", isometryToJson(record.T_C_D)},
             {"K", json::array({record.K_depth.fx, record.K_depth.fy, record.K_depth.cx,
                                record.K_depth.cy, record.K_depth.width, record.K_depth.height})},
             {"depth", depthToJson(record.depth, blobs)},
             {"views", views}};
  if (record.has_floor) entry["floor_point"] = json_fields::vectorToJson(record.floor_point_D);
  if (record.depth_coarse && !record.depth.empty()) entry["depth_coarse"] = true;
  if (record.refined_after) entry["refined_after"] = true;
  return entry;
}

json poseToJson(const Eigen::Isometry3d& T) { return isometryToJson(T); }

json historyToJson(const std::deque<KeyframeRecord>& records) {
  json out = json::array();
  for (const KeyframeRecord& record : records) out.push_back(recordToJson(record, nullptr));
  return out;
}

Status historyFromJson(const json& value, const std::string& path,
                       std::deque<KeyframeRecord>* records) {
  if (!value.is_array()) return fieldError(path, "expected an array of keyframes");
  std::deque<KeyframeRecord> loaded;
  for (std::size_t i = 0; i < value.size(); ++i) {
    KeyframeRecord record;
    const Status status =
        recordFromJson(value[i], path + "[" + std::to_string(i) + "]", nullptr, &record);
    if (!status) return status;
    if (!loaded.empty() && !(record.keyframe > loaded.back().keyframe)) {
      return fieldError(path + "[" + std::to_string(i) + "]",
                        "keyframes must come in keyframe order");
    }
    loaded.push_back(std::move(record));
  }
  *records = std::move(loaded);
  return Status::Ok();
}

}  // namespace history_json
}  // namespace mvod
