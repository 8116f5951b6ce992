// A SLAM's poses instead of a dataset's own (offline_detection and dataset_to_bag --trajectory,
// --keyframes): the TUM trajectory format ORB-SLAM2 and most SLAM systems write, one line
// "t tx ty tz qx qy qz qw" per pose (camera to world, the camera the SLAM tracked: the colour
// camera), '#' comments.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "multiview_object_detection/datasets/dataset_source.h"

namespace mvod {

struct StampedPose {
  double stamp_s = 0.0;
  Eigen::Isometry3d T_W_C = Eigen::Isometry3d::Identity();  // colour camera -> the SLAM's world
};

// The poses of a TUM trajectory file, ascending by stamp. Malformed lines (not 8 finite numbers, a
// quaternion whose norm is not 1 within 1e-2) are errors naming the file and line.
Status readTumTrajectory(const std::string& path, std::vector<StampedPose>* poses);

struct TrajectoryOptions {
  std::string trajectory;  // every frame's pose (CameraTrajectory.txt)
  // Only the frames at these stamps are kept, with these poses (KeyFrameTrajectory.txt: the
  // keyframes' final, optimised poses). Alone, or with `trajectory` (then only its keyframes).
  std::string keyframes;
  // The SLAM's world placed so that the first kept frame has the dataset's own pose, so the map
  // lies in the dataset's world (its gravity file, an annotation). Else the SLAM's world as it is,
  // its gravity unknown (estimated from the data).
  bool align_first_frame = true;
  double max_stamp_diff_s = 0.5 / 30.0;  // a pose belongs to the frame within half a frame
};

// Makes `source` give the trajectory's poses: a frame's T_W_D = T_W_C * T_C_D. Frames with no pose
// within max_stamp_diff_s are left out (said in source->notes). Fails on an unreadable file, or
// when no frame has a pose.
Status applyTrajectory(const TrajectoryOptions& options, DatasetSource* source);

}  // namespace mvod
