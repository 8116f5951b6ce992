// SyntheticScene::writeSceneNN: the frames as a SceneNN sequence (shared/formats/scenenn.md).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "multiview_object_detection/io/ply_writer.h"
#include "multiview_object_detection/simulation/dataset_files.h"
#include "multiview_object_detection/simulation/ground_truth_voxels.h"
#include "multiview_object_detection/simulation/renderer.h"
#include "multiview_object_detection/simulation/synthetic_scene.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;
using simulation::accumulateFrame;
using simulation::classColor;
using simulation::formatNumber;
using simulation::makeFolder;
using simulation::RenderOutput;
using simulation::renderScene;
using simulation::VoxelAccumulator;
using simulation::writeImage;
using simulation::writeText;

// z-up world -> SceneNN's y-up world: (x, y, z) -> (x, z, -y).
Eigen::Matrix3d zUpToYUp() {
  Eigen::Matrix3d M;
  M << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  return M;
}

std::string nyuClassName(const std::string& name) {
  static const std::map<std::string, std::string> kNyu = {
      {"chair", "chair"},
      {"dining table", "table"},
      {"couch", "sofa"},
      {"bed", "bed"},
      {"tv", "television"},
      {"book", "books"},
      {"refrigerator", "refridgerator"},  // NYU40's spelling
      {"cup", "cup"},
      {"shelf", "shelves"},
      {"tv stand", "cabinet"},
      {"night stand", "night stand"},
      {"side table", "otherfurniture"}};
  const auto it = kNyu.find(name);
  return it == kNyu.end() ? std::string() : it->second;
}

// Frame i's colour, depth and label images (image/imageNNNNN.png ..., NNNNN = i + 1).
Status writeFrameImages(const fs::path& dir, int i, const RenderOutput& out) {
  char buffer[256];
  std::snprintf(buffer, sizeof(buffer), "%05d", i + 1);
  const std::string number = buffer;
  Status status;
  if (!(status = writeImage(dir / "image" / ("image" + number + ".png"), out.color))) {
    return status;
  }
  if (!(status = writeImage(dir / "depth" / ("depth" + number + ".png"), out.depth_mm))) {
    return status;
  }
  cv::Mat labels16;
  out.labels.convertTo(labels16, CV_16UC1);  // saturates; ids stay far below 65535
  if (!(status = writeImage(dir / "label" / ("label" + number + ".png"), labels16))) {
    return status;
  }
  return Status::Ok();
}

// Frame i's block of trajectory.log: "i i i+1" and the camera (optical) -> y-up world matrix.
std::string trajectoryBlock(int i, const Eigen::Isometry3d& T_W_C, const Eigen::Matrix3d& M) {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = M * T_W_C.linear();
  T.topRightCorner<3, 1>() = M * T_W_C.translation();
  std::string trajectory =
      std::to_string(i) + " " + std::to_string(i) + " " + std::to_string(i + 1) + "\n";
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) trajectory += formatNumber(T(r, c)) + (c < 3 ? " " : "\n");
  }
  return trajectory;
}

// Frame i's line of timestamp.txt: colour and depth at 30 Hz from 0, in microseconds.
std::string timestampLine(int i) {
  const long long stamp_us = std::llround(i * 1e6 / 30.0);
  return std::to_string(i + 1) + " " + std::to_string(stamp_us) + " " + std::to_string(stamp_us) +
         "\n";
}

std::string asusIni(const CameraIntrinsics& K) {
  return "fx " + formatNumber(K.fx) + "\nfy " + formatNumber(K.fy) + "\ncx " + formatNumber(K.cx) +
         "\ncy " + formatNumber(K.cy) + "\ndepth_width " + std::to_string(K.width) +
         "\ndepth_height " + std::to_string(K.height) + "\n";
}

// One <label .../> of the annotation: the true box in the y-up frame (M), the class colour.
std::string labelXml(int label_id, const SyntheticObject& object, const Eigen::Matrix3d& M) {
  const OrientedBox& box = object.box;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const Eigen::Vector3d& corner : box.corners()) {
    lo = lo.cwiseMin(M * corner);
    hi = hi.cwiseMax(M * corner);
  }
  const Eigen::Vector3d center = M * box.center_m;
  const Eigen::Quaterniond q(M * box.rotation);
  const cv::Vec3d bgr = classColor(object.class_name);
  std::string xml = "  <label id=\"" + std::to_string(label_id) + "\" text=\"" + object.class_name +
                    "\" nyu_class=\"" + nyuClassName(object.class_name) + "\" aabbox=\"";
  for (int a = 0; a < 3; ++a) xml += formatNumber(lo[a]) + " ";
  for (int a = 0; a < 3; ++a) xml += formatNumber(hi[a]) + (a < 2 ? " " : "\" obbox=\"");
  for (int a = 0; a < 3; ++a) xml += formatNumber(center[a]) + " ";
  for (int a = 0; a < 3; ++a) xml += formatNumber(box.size_m[a]) + " ";
  xml += formatNumber(q.x()) + " " + formatNumber(q.y()) + " " + formatNumber(q.z()) + " " +
         formatNumber(q.w()) + "\" color=\"" + std::to_string(static_cast<int>(bgr[2])) + " " +
         std::to_string(static_cast<int>(bgr[1])) + " " + std::to_string(static_cast<int>(bgr[0])) +
         "\"/>\n";
  return xml;
}

// Annotation: one label per object and per clutter piece.
std::string annotationXml(const SyntheticScene& scene, const Eigen::Matrix3d& M) {
  std::string xml = "<annotation>\n";
  for (size_t k = 0; k < scene.objects().size(); ++k) {
    xml += labelXml(scene.sceneNNObjectId(static_cast<int>(k)), scene.objects()[k], M);
  }
  for (size_t j = 0; j < scene.clutter().size(); ++j) {
    xml += labelXml(scene.sceneNNClutterId(static_cast<int>(j)), scene.clutter()[j], M);
  }
  return xml + "</annotation>\n";
}

// The observed surface as a labelled vertex cloud (binary little-endian PLY), y-up.
std::string surfacePly(const VoxelAccumulator& surface, const Eigen::Matrix3d& M) {
  std::vector<PlyColoredVertex> vertices;
  vertices.reserve(surface.voxels().size());
  for (const VoxelAccumulator::Voxel& voxel : surface.voxels()) {
    const Eigen::Vector3d p = M * (voxel.sum / voxel.count);
    PlyColoredVertex vertex;
    vertex.xyz[0] = static_cast<float>(p.x());
    vertex.xyz[1] = static_cast<float>(p.y());
    vertex.xyz[2] = static_cast<float>(p.z());
    for (int c = 0; c < 3; ++c) {  // BGR sums -> RGB
      vertex.rgb[c] = static_cast<uint8_t>(voxel.bgr[2 - c] / voxel.count);
    }
    vertex.label = static_cast<uint16_t>(std::clamp(voxel.label, 0, 65535));
    vertices.push_back(vertex);
  }
  return plyBinaryColoredLabelled(
      "synthetic SceneNN-layout sequence (multiview_object_detection), y-up", vertices);
}

}  // namespace

Status SyntheticScene::writeSceneNN(const std::string& sequence_dir, const std::string& id) const {
  if (sequence_dir.empty()) return Status::Error("writeSceneNN: sequence folder is empty");
  if (id.empty() || id.find_first_of("/\\<>\"&") != std::string::npos) {
    return Status::Error("writeSceneNN: bad sequence id '" + id + "'");
  }
  const fs::path dir(sequence_dir);
  Status status;
  for (const fs::path& folder : {dir, dir / "image", dir / "depth", dir / "label"}) {
    if (!(status = makeFolder(folder.string()))) return status;
  }
  // SceneNN's camera, whatever config().K is.
  SyntheticSceneConfig config = config_;
  config.K = sceneNNIntrinsics();
  const SyntheticScene view(config, objects_, clutter_);
  const CameraIntrinsics& K = config.K;
  const Eigen::Matrix3d M = zUpToYUp();

  std::string trajectory, timestamps;
  VoxelAccumulator surface(0.01);
  for (int i = 0; i < config.num_frames; ++i) {
    RenderOutput out;
    renderScene(view, i, K, /*clutter_ids=*/true, /*sensor_model=*/true, &out);
    if (!(status = writeFrameImages(dir, i, out))) return status;
    const Eigen::Isometry3d T_W_C = view.cameraPose(i);
    accumulateFrame(config, K, T_W_C, out, out.labels, 0, &surface);
    trajectory += trajectoryBlock(i, T_W_C, M);
    timestamps += timestampLine(i);
  }
  if (!(status = writeText(dir / "trajectory.log", trajectory))) return status;
  if (!(status = writeText(dir / "timestamp.txt", timestamps))) return status;
  if (!(status = writeText(dir / "asus.ini", asusIni(K)))) return status;
  if (!(status = writeText(dir / (id + ".xml"), annotationXml(*this, M)))) return status;
  return writeText(dir / (id + ".ply"), surfacePly(surface, M));
}

}  // namespace mvod
