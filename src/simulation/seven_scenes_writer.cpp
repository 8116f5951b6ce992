// SyntheticScene::writeSevenScenes: frames in the 7-Scenes layout, perfect detections and
// ground_truth.json.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/detectors/file_instance_segmenter.h"
#include "multiview_object_detection/simulation/dataset_files.h"
#include "multiview_object_detection/simulation/ground_truth_voxels.h"
#include "multiview_object_detection/simulation/renderer.h"
#include "multiview_object_detection/simulation/synthetic_scene.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;
using simulation::accumulateObjectSurfaces;
using simulation::formatNumber;
using simulation::makeFolder;
using simulation::RenderOutput;
using simulation::renderScene;
using simulation::toRgbdFrame;
using simulation::VoxelAccumulator;
using simulation::writeImage;
using simulation::writeText;

// The label (object index) under the first pixel of a mask, -1 for an empty mask.
int objectIndexOfMask(const cv::Mat& labels, const cv::Mat& mask) {
  std::vector<cv::Point> pixels;
  cv::findNonZero(mask, pixels);
  if (pixels.empty()) return -1;
  return labels.at<int32_t>(pixels.front()) - 1;
}

// camera-intrinsics.txt, and gravity-direction.txt: world z is up, gravity points down.
Status writeCalibration(const fs::path& dir, const CameraIntrinsics& K) {
  Status status = writeText(dir / "camera-intrinsics.txt",
                            formatNumber(K.fx) + " 0 " + formatNumber(K.cx) + "\n0 " +
                                formatNumber(K.fy) + " " + formatNumber(K.cy) + "\n0 0 1\n");
  if (!status) return status;
  return writeText(dir / "gravity-direction.txt", "0 0 -1\n");
}

// 4x4 camera-to-world, row-major, as 7-Scenes.
std::string poseText(const Eigen::Isometry3d& T_W_C) {
  const Eigen::Matrix4d T = T_W_C.matrix();
  std::string pose;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) pose += formatNumber(T(r, c)) + (c < 3 ? " " : "\n");
  }
  return pose;
}

// A detector misses objects that are mostly hidden or out of view; their slivers would also give
// boxes far from the object's centre: only objects at least min_visible_fraction visible.
Status writeDetections(const SyntheticScene& scene, int i, const cv::Mat& labels,
                       const std::string& detections_dir, const std::string& name) {
  std::vector<Detection2D> detections;
  for (Detection2D& detection : scene.detectionsFromLabels(labels)) {
    const int k = objectIndexOfMask(labels, detection.mask);
    if (k >= 0 && scene.visibleFraction(i, labels, k) >= scene.config().min_visible_fraction) {
      detections.push_back(std::move(detection));
    }
  }
  return FileInstanceSegmenter::write(detections_dir, name, detections);
}

// Frame i: colour, depth, pose (and detections); the observed surface of its objects goes into
// surfaces.
Status writeFrame(const SyntheticScene& scene, int i, const fs::path& dir,
                  const std::string& detections_dir, std::vector<VoxelAccumulator>* surfaces) {
  const CameraIntrinsics& K = scene.config().K;
  if (!(K.width > 0 && K.height > 0 && K.isValid())) {
    return Status::Error("writeSevenScenes: cannot render frame " + std::to_string(i) +
                         " (invalid intrinsics " + std::to_string(K.width) + "x" +
                         std::to_string(K.height) + ")");
  }
  RenderOutput out;
  renderScene(scene, i, K, /*clutter_ids=*/false, /*sensor_model=*/true, &out);
  const RgbdFrame frame = toRgbdFrame(scene, i, K, out);
  accumulateObjectSurfaces(scene.config(), K, frame.T_W_D, out, surfaces);
  Status status = writeImage(dir / (frame.name + ".color.png"), frame.color_bgr);
  if (!status) return status;
  status = writeImage(dir / (frame.name + ".depth.png"), frame.depth);
  if (!status) return status;
  if (!(status = writeText(dir / (frame.name + ".pose.txt"), poseText(frame.T_W_D)))) return status;
  if (detections_dir.empty()) return Status::Ok();
  return writeDetections(scene, i, out.labels, detections_dir, frame.name);
}

// ground_truth.json: the boxes, each object's observed surface in millimetres precision, the
// number of frames.
std::string groundTruthJson(const std::vector<SyntheticObject>& objects_,
                            const std::vector<VoxelAccumulator>& surfaces, int num_frames) {
  nlohmann::json objects = nlohmann::json::array();
  std::vector<std::string> point_texts;
  for (size_t k = 0; k < objects_.size(); ++k) {
    const SyntheticObject& object = objects_[k];
    const OrientedBox& box = object.box;
    nlohmann::json rotation = nlohmann::json::array();
    for (int r = 0; r < 3; ++r) {
      rotation.push_back({box.rotation(r, 0), box.rotation(r, 1), box.rotation(r, 2)});
    }
    objects.push_back({{"class_name", object.class_name},
                       {"center", {box.center_m.x(), box.center_m.y(), box.center_m.z()}},
                       {"size", {box.size_m.x(), box.size_m.y(), box.size_m.z()}},
                       {"rotation", rotation},
                       {"yaw", std::atan2(box.rotation(1, 0), box.rotation(0, 0))},
                       {"points", "@POINTS" + std::to_string(k) + "@"}});
    // One compact line of points (millimetres), spliced in below: dump(2) would give each number
    // its own line.
    std::string text = "[";
    char buffer[96];
    for (const VoxelAccumulator::Voxel& voxel : surfaces[k].voxels()) {
      const Eigen::Vector3d p = voxel.sum / voxel.count;
      std::snprintf(buffer, sizeof(buffer), "%s[%.3f,%.3f,%.3f]", text.size() > 1 ? "," : "", p.x(),
                    p.y(), p.z());
      text += buffer;
    }
    point_texts.push_back(text + "]");
  }
  nlohmann::json ground_truth = {{"objects", objects}, {"frames", num_frames}};
  std::string json_text = ground_truth.dump(2) + "\n";
  for (size_t k = 0; k < point_texts.size(); ++k) {
    const std::string placeholder = "\"@POINTS" + std::to_string(k) + "@\"";
    const size_t at = json_text.find(placeholder);
    if (at != std::string::npos) json_text.replace(at, placeholder.size(), point_texts[k]);
  }
  return json_text;
}

}  // namespace

Status SyntheticScene::writeSevenScenes(const std::string& dataset_dir,
                                        const std::string& detections_dir) const {
  if (dataset_dir.empty()) return Status::Error("writeSevenScenes: dataset folder is empty");
  Status status = makeFolder(dataset_dir);
  if (!status) return status;
  if (!detections_dir.empty() && !(status = makeFolder(detections_dir))) return status;
  const fs::path dir(dataset_dir);
  if (!(status = writeCalibration(dir, config_.K))) return status;
  // The observed surface of each object: its pixels' exact depth, on a 1.5 cm grid.
  std::vector<VoxelAccumulator> surfaces(objects_.size(), VoxelAccumulator(0.015));
  for (int i = 0; i < config_.num_frames; ++i) {
    if (!(status = writeFrame(*this, i, dir, detections_dir, &surfaces))) return status;
  }
  return writeText(dir / "ground_truth.json",
                   groundTruthJson(objects_, surfaces, config_.num_frames));
}

}  // namespace mvod
