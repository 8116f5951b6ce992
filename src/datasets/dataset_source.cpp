#include "multiview_object_detection/datasets/dataset_source.h"

#include <cstdio>
#include <filesystem>
#include <memory>
#include <system_error>
#include <utility>

#include "multiview_object_detection/datasets/dataset.h"
#include "multiview_object_detection/datasets/scenenn_dataset.h"
#include "multiview_object_detection/pipeline/types/intrinsics_check.h"

namespace mvod {
namespace {

// A loaded frame's intrinsics against its images, the check the node makes of camera_info: a K
// that is not the camera's (another camera's file, a typo) misplaces every object or blows up the
// cloud. depth_file / color_file name where each K came from.
Status checkFrameIntrinsics(const RgbdFrame& frame, const std::string& depth_file,
                            const std::string& color_file) {
  Status status = checkIntrinsicsForImage(frame.K_depth, frame.depth.cols, frame.depth.rows);
  if (!status) {
    return Status::Error(depth_file + ": " + status.message() + " (depth of " + frame.name + ")");
  }
  if (frame.registered) return Status::Ok();
  status = checkIntrinsicsForImage(frame.K_color, frame.color_bgr.cols, frame.color_bgr.rows);
  if (!status) {
    return Status::Error(color_file + ": " + status.message() + " (colour of " + frame.name + ")");
  }
  return Status::Ok();
}

}  // namespace

std::string nameFirstFrames(const std::vector<int>& indices, size_t max_named,
                            const std::function<std::string(int)>& name) {
  std::string names;
  size_t named = 0;
  for (const int index : indices) {
    if (named == max_named) break;
    names += (named++ == 0 ? "" : ", ") + name(index);
  }
  if (indices.size() > named) names += " and " + std::to_string(indices.size() - named) + " more";
  return names;
}

namespace {

namespace fs = std::filesystem;

// The layout of `dir`: `format` unless it is "auto", then found from the folder's files.
Status datasetLayout(const fs::path& dir, const std::string& format, std::string* layout) {
  std::error_code error;
  const std::string directory = dir.string();
  *layout = format;
  if (*layout == "auto") {
    if (fs::exists(dir / "trajectory.log", error) || fs::is_directory(dir / "depth", error)) {
      *layout = "scenenn";
    } else if (fs::exists(dir / "camera-intrinsics.txt", error)) {
      *layout = "7scenes";
    } else {
      return Status::Error(directory +
                           ": neither a SceneNN sequence (trajectory.log, depth/) nor a 7-Scenes "
                           "folder (camera-intrinsics.txt); say which layout it has");
    }
  }
  if (*layout != "7scenes" && *layout != "scenenn") {
    return Status::Error("unknown dataset format '" + format + "' (auto, 7scenes or scenenn)");
  }
  return Status::Ok();
}

// A 7-Scenes-layout folder: its frames with their intrinsics checked, the stated gravity, and
// whether colour and depth are one camera.
Status openSevenScenes(const std::string& directory, const ColorCameraFiles& camera,
                       DatasetSource* source) {
  auto dataset = std::make_shared<SevenScenesDataset>();
  const Status status = SevenScenesDataset::open(directory, dataset.get(), camera);
  if (!status) return status;
  source->indices = dataset->frameIndices();
  source->frame_name = [](int index) { return SevenScenesDataset::frameName(index); };
  const std::string depth_file = (fs::path(directory) / "camera-intrinsics.txt").string();
  const std::string color_file = camera.color_intrinsics.empty()
                                     ? (fs::path(directory) / "color-intrinsics.txt").string()
                                     : camera.color_intrinsics;
  source->load = [dataset, depth_file, color_file](int index, RgbdFrame* frame) {
    RgbdFrame loaded;
    const Status status = dataset->load(index, &loaded);
    if (!status) return status;
    const Status intrinsics = checkFrameIntrinsics(loaded, depth_file, color_file);
    if (!intrinsics) return intrinsics;
    *frame = std::move(loaded);
    return Status::Ok();
  };
  source->check = [](int) { return Status::Ok(); };
  source->stamp_s = [](int index) { return SevenScenesDataset::stampOf(index); };
  source->warnings = dataset->warnings();
  source->has_gravity = dataset->hasGravity();
  source->gravity_down_W = dataset->gravityDown_W();
  if (dataset->hasGravity()) {
    const Eigen::Vector3d g = dataset->gravityDown_W();
    char text[160];
    std::snprintf(text, sizeof(text), "world gravity (gravity-direction.txt) [%.4f, %.4f, %.4f]",
                  g.x(), g.y(), g.z());
    source->notes.push_back(text);
  }
  if (!dataset->registered()) {
    source->notes.push_back("colour and depth are two cameras (" + color_file +
                            "): depth is registered to the colour camera");
  } else if (camera.registered) {
    source->notes.push_back("colour and depth are registered (--registered): one camera");
  } else {
    source->warnings.push_back(
        directory +
        " has no color-intrinsics.txt: colour and depth are taken as one camera "
        "(camera-intrinsics.txt for both). Real 7-Scenes (Kinect v1) colour is a second camera: "
        "give its K with --color-intrinsics FILE (the Kinect v1 default is 525 0 320 / 0 525 240 "
        "/ 0 0 1) and the offset with --depth-to-color FILE, or masks land on the wrong depth "
        "pixels; --registered says they are one camera and silences this");
  }
  return Status::Ok();
}

// A SceneNN sequence: its frames with their intrinsics checked; its world is y-up.
Status openSceneNN(const std::string& directory, DatasetSource* source) {
  auto dataset = std::make_shared<SceneNNDataset>();
  const Status status = SceneNNDataset::open(directory, dataset.get());
  if (!status) return status;
  source->indices = dataset->frameIndices();
  source->frame_name = [](int index) { return SceneNNDataset::frameName(index); };
  const std::string intrinsics_file = dataset->intrinsicsPath().empty()
                                          ? "SceneNN default intrinsics (no asus.ini)"
                                          : dataset->intrinsicsPath();
  source->load = [dataset, intrinsics_file](int index, RgbdFrame* frame) {
    RgbdFrame loaded;
    const Status status = dataset->load(index, &loaded);
    if (!status) return status;
    const Status intrinsics = checkFrameIntrinsics(loaded, intrinsics_file, intrinsics_file);
    if (!intrinsics) return intrinsics;
    *frame = std::move(loaded);
    return Status::Ok();
  };
  source->check = [dataset](int index) { return dataset->checkFrame(index); };
  source->stamp_s = [dataset](int index) { return dataset->stampOf(index); };
  source->warnings = dataset->warnings();
  source->has_timestamps = dataset->hasTimestamps();
  // The SceneNN mesh and trajectory frame is y-up (shared/formats/scenenn.md).
  source->has_gravity = true;
  source->gravity_down_W = Eigen::Vector3d(0, -1, 0);
  const CameraIntrinsics& K = dataset->intrinsics();
  char text[200];
  std::snprintf(text, sizeof(text), "intrinsics fx %.3f fy %.3f cx %.2f cy %.2f from %s", K.fx,
                K.fy, K.cx, K.cy,
                dataset->intrinsicsPath().empty() ? "SceneNN defaults (no asus.ini)"
                                                  : dataset->intrinsicsPath().c_str());
  source->notes.push_back(text);
  source->notes.push_back("SceneNN's world is y-up: gravity (0, -1, 0)");
  if (!dataset->hasTimestamps()) source->notes.push_back("no timestamp.txt");
  return Status::Ok();
}

}  // namespace

Status openDatasetSource(const std::string& directory, const std::string& format,
                         DatasetSource* source, const ColorCameraFiles& camera) {
  const fs::path dir(directory);
  std::error_code error;
  if (!fs::is_directory(dir, error)) {
    return Status::Error(
        directory + ": " +
        (fs::exists(dir, error) ? "not a folder" : "dataset folder does not exist"));
  }
  std::string layout;
  const Status known = datasetLayout(dir, format, &layout);
  if (!known) return known;
  DatasetSource opened;
  opened.format = layout;
  opened.directory = directory;
  if (layout != "7scenes" && !camera.empty()) {
    return Status::Error(directory +
                         ": colour camera files and --registered are for 7-Scenes-layout "
                         "folders (a SceneNN sequence's colour and depth are one camera)");
  }
  const Status status = layout == "7scenes" ? openSevenScenes(directory, camera, &opened)
                                            : openSceneNN(directory, &opened);
  if (!status) return status;
  *source = std::move(opened);
  return Status::Ok();
}

}  // namespace mvod
