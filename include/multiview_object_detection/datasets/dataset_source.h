// One interface over the dataset readers (7-Scenes layout, SceneNN sequence), for the tools that
// walk a dataset frame by frame: offline_detection, dataset_to_bag, the ablation runs.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "multiview_object_detection/datasets/dataset.h"
#include "multiview_object_detection/pipeline/types/rgbd_frame.h"

namespace mvod {

struct DatasetSource {
  std::string format;  // "7scenes" or "scenenn"
  std::string directory;
  std::vector<int> indices;  // frame numbers, ascending (7-Scenes: 0-based, SceneNN: 1-based)
  std::function<std::string(int)> frame_name;  // "frame-000010" / "image00011"
  // The message names the file. The intrinsics are checked against the images as the node checks
  // camera_info (checkIntrinsicsForImage), the message naming the intrinsics file.
  std::function<Status(int, RgbdFrame*)> load;
  std::function<Status(int)> check;    // cheap per-frame checks (no image read)
  std::function<double(int)> stamp_s;  // the frame's stamp as load() gives it (no image read)
  bool has_timestamps = false;         // SceneNN with timestamp.txt
  // World gravity (pointing down) the dataset states: 7-Scenes' gravity-direction.txt, SceneNN's
  // y-up world (0, -1, 0). has_gravity false = unknown (estimate it).
  bool has_gravity = false;
  Eigen::Vector3d gravity_down_W = Eigen::Vector3d(0, 0, -1);
  std::vector<std::string> notes;  // what a user should know (intrinsics source, registration ...)
  // What may make the results wrong (printed even by quiet tools).
  std::vector<std::string> warnings;
};

// "a, b, c, d, e and K more": the first max_named of `indices` (ascending) by name, for warnings
// about files a dataset folder lacks.
std::string nameFirstFrames(const std::vector<int>& indices, size_t max_named,
                            const std::function<std::string(int)>& name);

// format: "auto" (trajectory.log or depth/ -> SceneNN, camera-intrinsics.txt -> 7-Scenes),
// "7scenes" or "scenenn". Fails with a message naming the folder or file.
// camera: the colour camera's files apart from the folder (7-Scenes layout only; an error for
// SceneNN).
Status openDatasetSource(const std::string& directory, const std::string& format,
                         DatasetSource* source, const ColorCameraFiles& camera = {});

}  // namespace mvod
