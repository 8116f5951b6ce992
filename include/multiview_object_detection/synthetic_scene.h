// A small deterministic synthetic indoor scene with known oriented boxes, rendered to RGB-D frames with
// instance labels by ray casting. Used by the tests, `make demo` and the benchmarks: it has ground truth.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/detection.h"
#include "multiview_object_detection/oriented_box.h"
#include "multiview_object_detection/rgbd_frame.h"

namespace mvod {

struct SyntheticObject {
  std::string class_name;
  OrientedBox box;       // world frame, z up
};

struct SyntheticSceneConfig {
  unsigned int seed = 1;
  double room_size_x_m = 5.0;     // floor [0, x] x [0, y] at z = 0, walls around, ceiling at room_height
  double room_size_y_m = 4.0;
  double room_height_m = 2.6;
  int num_frames = 60;
  double camera_height_m = 1.2;   // robot-mounted camera looking roughly level
  double camera_pitch_deg = -20;  // negative = looking down
  CameraIntrinsics K{525.0, 525.0, 319.5, 239.5, 640, 480};
  double depth_noise_m_per_m2 = 0.0;  // Kinect-like noise sigma = k * z^2 (0 = clean)
  double hole_fraction = 0.0;         // random invalid depth pixels
};

class SyntheticScene {
 public:
  // The default scene: a table, chairs around it, a couch, a tv on a stand, cups and a book on the table.
  static SyntheticScene makeDefault(const SyntheticSceneConfig& config);
  SyntheticScene(const SyntheticSceneConfig& config, std::vector<SyntheticObject> objects);

  const std::vector<SyntheticObject>& objects() const { return objects_; }
  const SyntheticSceneConfig& config() const { return config_; }
  // Camera (optical frame: z forward, y down) to world for frame i: a loop around the room centre.
  Eigen::Isometry3d cameraPose(int frame) const;
  // Renders frame i: 16-bit mm depth, BGR colour, and a label image (CV_32SC1: 0 = background/room,
  // k = objects()[k-1]).
  void render(int frame, RgbdFrame* rgbd, cv::Mat* labels) const;
  // Perfect detections from a label image (masks of visible pixels, min_pixels or more).
  std::vector<Detection2D> detectionsFromLabels(const cv::Mat& labels, int min_pixels = 200) const;

  // Writes frames in the 7-Scenes layout to `dataset_dir` and (if not empty) perfect detections with mask
  // PNGs to `detections_dir`, plus ground_truth.json with the boxes.
  Status writeSevenScenes(const std::string& dataset_dir, const std::string& detections_dir) const;

 private:
  SyntheticSceneConfig config_;
  std::vector<SyntheticObject> objects_;
};

}  // namespace mvod
