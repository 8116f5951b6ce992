// SyntheticScene: the scene (objects, clutter, config), its camera trajectory, rendering and the
// perfect detections of its label images. The rooms are room_layouts.cpp, the dataset writers
// seven_scenes_writer.cpp and scenenn_writer.cpp.
#include "multiview_object_detection/simulation/synthetic_scene.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/imgproc.hpp>

#include "multiview_object_detection/pipeline/types/class_priors.h"
#include "multiview_object_detection/simulation/renderer.h"
#include "multiview_object_detection/simulation/scene_geometry.h"
#include "multiview_object_detection/simulation/split_mix.h"

namespace mvod {

using simulation::deg2rad;

namespace {

// Every tv stands on a stand: a background box from the floor up to the tv, a little wider and
// deeper, flush with the tv's back (it is not one of objects(), so it has no label).
std::vector<SyntheticObject> clutterBoxes(const std::vector<SyntheticObject>& objects) {
  std::vector<SyntheticObject> clutter;
  for (const SyntheticObject& object : objects) {
    if (object.class_name != "tv") continue;
    const OrientedBox& tv = object.box;
    const double bottom_z_m = tv.center_m.z() - 0.5 * tv.size_m.z();
    if (bottom_z_m < 0.05) continue;
    OrientedBox stand;
    stand.rotation = tv.rotation;
    stand.size_m = Eigen::Vector3d(tv.size_m.x() + 0.2, std::max(0.4, tv.size_m.y()), bottom_z_m);
    // The stand's back is flush with the tv's back (-y side of the tv), it reaches out in front.
    const Eigen::Vector3d back = tv.center_m - 0.5 * tv.size_m.y() * tv.rotation.col(1);
    stand.center_m = back + 0.5 * stand.size_m.y() * tv.rotation.col(1);
    stand.center_m.z() = 0.5 * bottom_z_m;
    clutter.push_back({"tv stand", stand, {}});
  }
  return clutter;
}
}  // namespace

std::vector<OrientedBox> solidParts(const SyntheticObject& object) {
  return object.parts.empty() ? std::vector<OrientedBox>{object.box} : object.parts;
}

SyntheticScene::SyntheticScene(const SyntheticSceneConfig& config,
                               std::vector<SyntheticObject> objects)
    : config_(config), objects_(std::move(objects)), clutter_(clutterBoxes(objects_)) {}

SyntheticScene::SyntheticScene(const SyntheticSceneConfig& config,
                               std::vector<SyntheticObject> objects,
                               std::vector<SyntheticObject> clutter)
    : config_(config), objects_(std::move(objects)), clutter_(std::move(clutter)) {}

CameraIntrinsics SyntheticScene::sceneNNIntrinsics() {
  return CameraIntrinsics{544.47329, 544.47329, 320.0, 240.0, 640, 480};
}

Eigen::Isometry3d SyntheticScene::cameraPose(int frame) const {
  // A robot driving an ellipse around the room centre, its camera turned towards the centre: every
  // object inside the loop is seen from all sides over one lap.
  const int frames = std::max(1, config_.num_frames);
  const double angle = kPi + 2.0 * kPi * static_cast<double>(frame) / frames;
  const Eigen::Vector2d center(0.5 * config_.room_size_x_m, 0.5 * config_.room_size_y_m);
  const double inset = config_.camera_loop_inset_m;
  const double radius_x = std::max(0.5, 0.5 * config_.room_size_x_m - inset);
  const double radius_y = std::max(0.5, 0.5 * config_.room_size_y_m - inset);
  Eigen::Vector3d position(center.x() + radius_x * std::cos(angle),
                           center.y() + radius_y * std::sin(angle), config_.camera_height_m);
  double yaw = std::atan2(center.y() - position.y(), center.x() - position.x());
  double pitch = deg2rad(config_.camera_pitch_deg);
  if (config_.camera_wobble) {
    // A robot's bumps and steering: smooth, whole cycles per lap (the lap closes), seeded phases.
    SplitMix64 rng(mixSeed(config_.seed, 0x30bb1e));
    double phase[4];
    for (double& p : phase) p = rng.uniform(0.0, 2.0 * kPi);
    const double s = 2.0 * kPi * static_cast<double>(frame) / frames;
    position.z() += config_.wobble_height_m * std::sin(3.0 * s + phase[0]);
    yaw += deg2rad(config_.wobble_yaw_deg) *
           (0.7 * std::sin(2.0 * s + phase[1]) + 0.3 * std::sin(5.0 * s + phase[2]));
    pitch += deg2rad(config_.wobble_pitch_deg) * std::sin(4.0 * s + phase[3]);
  }

  // Optical frame: z forward, x right, y down.
  const Eigen::Vector3d forward(std::cos(yaw) * std::cos(pitch), std::sin(yaw) * std::cos(pitch),
                                std::sin(pitch));
  const Eigen::Vector3d right(std::sin(yaw), -std::cos(yaw), 0.0);
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Isometry3d T_W_C = Eigen::Isometry3d::Identity();
  T_W_C.linear().col(0) = right;
  T_W_C.linear().col(1) = down;
  T_W_C.linear().col(2) = forward;
  T_W_C.translation() = position;
  return T_W_C;
}

void SyntheticScene::render(int frame, RgbdFrame* rgbd, cv::Mat* labels) const {
  const CameraIntrinsics& K = config_.K;
  if (rgbd == nullptr && labels == nullptr) return;
  if (K.width <= 0 || K.height <= 0 || !K.isValid()) {
    if (rgbd != nullptr) *rgbd = RgbdFrame();
    if (labels != nullptr) *labels = cv::Mat();
    return;
  }
  simulation::RenderOutput out;
  simulation::renderScene(*this, frame, K, /*clutter_ids=*/false, /*sensor_model=*/true, &out);
  if (rgbd != nullptr) *rgbd = simulation::toRgbdFrame(*this, frame, K, out);
  if (labels != nullptr) *labels = out.labels;
}

std::vector<Detection2D> SyntheticScene::detectionsFromLabels(const cv::Mat& labels,
                                                              int min_pixels) const {
  std::vector<Detection2D> detections;
  if (labels.empty() || labels.type() != CV_32SC1) return detections;
  const int count = static_cast<int>(objects_.size());
  std::vector<int> pixels(count + 1, 0);
  std::vector<cv::Rect> boxes(count + 1);
  std::vector<int> min_u(count + 1, labels.cols), max_u(count + 1, -1);
  std::vector<int> min_v(count + 1, labels.rows), max_v(count + 1, -1);
  for (int v = 0; v < labels.rows; ++v) {
    const int32_t* row = labels.ptr<int32_t>(v);
    for (int u = 0; u < labels.cols; ++u) {
      const int k = row[u];
      if (k <= 0 || k > count) continue;
      ++pixels[k];
      min_u[k] = std::min(min_u[k], u);
      max_u[k] = std::max(max_u[k], u);
      min_v[k] = std::min(min_v[k], v);
      max_v[k] = std::max(max_v[k], v);
    }
  }
  for (int k = 1; k <= count; ++k) {
    if (pixels[k] == 0 || pixels[k] < min_pixels) continue;
    const SyntheticObject& object = objects_[k - 1];
    if (object.class_name.empty()) continue;
    Detection2D detection;
    detection.class_name = object.class_name;
    detection.class_id = cocoClassId(object.class_name);
    // A fixed, slightly different confidence per object, as a detector would give.
    detection.score = 0.99f - 0.015f * static_cast<float>((k - 1) % 12);
    detection.box_px =
        cv::Rect(min_u[k], min_v[k], max_u[k] - min_u[k] + 1, max_v[k] - min_v[k] + 1);
    detection.mask = cv::Mat(labels == k);  // 255 on the object, 0 elsewhere
    detections.push_back(std::move(detection));
  }
  return detections;
}

double SyntheticScene::visibleFraction(int frame, const cv::Mat& labels, int object_index) const {
  if (object_index < 0 || object_index >= static_cast<int>(objects_.size()) || labels.empty() ||
      labels.type() != CV_32SC1 || !config_.K.isValid()) {
    return 0.0;
  }
  // Area of the convex hull of the projected corners: what the object would cover on an unbounded
  // image plane with nothing in front of it.
  const CameraIntrinsics& K = config_.K;
  const Eigen::Isometry3d T_C_W = cameraPose(frame).inverse();
  std::vector<cv::Point2f> corners_px;
  for (const Eigen::Vector3d& corner_W : objects_[object_index].box.corners()) {
    const Eigen::Vector3d corner_C = T_C_W * corner_W;
    if (corner_C.z() < 1e-3) return 0.0;
    corners_px.emplace_back(static_cast<float>(K.fx * corner_C.x() / corner_C.z() + K.cx),
                            static_cast<float>(K.fy * corner_C.y() / corner_C.z() + K.cy));
  }
  std::vector<cv::Point2f> hull;
  cv::convexHull(corners_px, hull);
  const double area_px = cv::contourArea(hull);
  if (!(area_px > 0.0)) return 0.0;
  const int visible_px = cv::countNonZero(labels == object_index + 1);
  return std::min(1.0, visible_px / area_px);
}

}  // namespace mvod
